"""``python -m MODULE ...`` and ``python -c CODE ...`` as real processes, forked from a program server that has
imported the program's modules already: for tests whose subject is the process (signals, exit by a signal, kill -9,
crashes, hangs, file-size limits), without each process compiling and importing ``master``, NumPy and fmpy again
(~0.25 s of CPU each, most of a short command's; this machine sets ``PYTHONDONTWRITEBYTECODE=1``).

    from program_server import Popen, run         # instead of subprocess.Popen / subprocess.run
    p = Popen([sys.executable, "-m", "master.cli", "run", ...], env=..., stdout=PIPE, start_new_session=True)

``Popen`` is ``subprocess.Popen`` (pipes, text mode, ``communicate``, ``poll``, ``wait`` with a timeout, ``send_signal``,
``returncode`` negative for a death by a signal); only the start differs. The server is one clean process per set of
start-up variables (below), started by the first test that needs it and stopped and reaped at the session's end (so
its children's CPU is counted with pytest's). It has imported the CLI with its run, campaign and report modules,
NumPy as the CLI loads it (OpenBLAS on one thread), fmpy and matplotlib's Figure and Agg canvas, and it has no
threads (checked: a fork copies only the thread that calls it); pyarrow, which starts a thread when it loads, is left
to the program. For each command it forks a child that becomes the program as ``exec`` would have made it from the
test process:

- stdin, stdout and stderr are the test's (pipes, files, or the test process's own), passed with ``send_fds``; no
  other descriptor is open; the environment, working directory and umask are the test's; ``start_new_session`` and
  ``process_group`` as subprocess does them; limits asked for with ``rlimits={resource.RLIMIT_...: (soft, hard)}``
  (there is no ``preexec_fn``: the server cannot run the test's code);
- signals: every handler default, the signals ignored in the test process ignored (except those ``restore_signals``
  resets), the test thread's signal mask (less the ``default_signals={signal.SIGINT, ...}`` asked for: handled by
  default and unblocked, as a ``preexec_fn`` resetting them makes them), then what Python's start does (SIGPIPE and
  SIGXFSZ ignored, SIGINT raising KeyboardInterrupt); ``sys.stdin/stdout/stderr`` made anew as Python makes them at
  start (line-buffered on a tty);
- ``sys.argv``, ``sys.path[0]`` and ``__main__`` as ``-m``/``-c`` set them, and the program runs as the interpreter
  runs it (``runpy``), so its exit is the program's: ``sys.exit`` and its status, a traceback and 1 for an uncaught
  error, death by SIGINT for an uncaught KeyboardInterrupt, ``atexit`` handlers, the interpreter's teardown, or the
  program's own ``os._exit``;
- the server tells the test its wait status when it ends and leaves it a zombie (its pid and process group taken)
  until the test polls or waits, then reaps it (``wait4``) and tells its CPU time (``ServedProcess.cpu``).

What a forked program cannot show, a real start must (those tests keep ``subprocess``): what is imported and in which
order (everything above is imported before the program starts: import audits, Ctrl-C during the imports), variables
read when the interpreter or a library starts (``PYTHON*``, the locale, matplotlib's, OpenBLAS/OpenMP thread counts:
a command asking for other values of the ``START_*`` ones gets a server of its own, and one asking for more than one
BLAS thread is refused), the entry-point script, the hash seed (shared by the server's children), the process's command line
(``/proc/PID/cmdline`` is the server's) and its parent (the server). ``COSIM_TEST_PROGRAM_SERVER=0`` starts every
command as a real subprocess instead, to check that a test passes both ways.
"""
from __future__ import annotations

import os
import pickle
import select
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

PIPE, STDOUT, DEVNULL = subprocess.PIPE, subprocess.STDOUT, subprocess.DEVNULL
TimeoutExpired, CalledProcessError, CompletedProcess = (subprocess.TimeoutExpired, subprocess.CalledProcessError,
                                                        subprocess.CompletedProcess)
REPO = Path(__file__).resolve().parents[1]
#: read when the interpreter starts (or NumPy loads): a server serves only commands with its own values
START_PREFIXES = ("PYTHON", "NPY_", "NUMPY_", "MPL", "MATPLOTLIB")
START_NAMES = ("LANG", "LC_ALL", "LC_CTYPE", "HOME", "XDG_CONFIG_HOME", "XDG_CACHE_HOME")
#: read by OpenBLAS/OpenMP when NumPy loads, which the server has done with one thread: a command asking for more
#: must start anew (one asking for 1, as dask's workers do, gets what it asks for)
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "GOTO_NUM_THREADS")
_MSG = 1 << 20


def served() -> bool:
    return os.environ.get("COSIM_TEST_PROGRAM_SERVER", "1") != "0"


# -- the test's side -------------------------------------------------------------------------------------------
def Popen(args, *, rlimits=None, default_signals=(), **kwargs):    # noqa: N802 - it stands for subprocess.Popen
    """``subprocess.Popen(args, **kwargs)``, forked from the program server (a real start with
    ``COSIM_TEST_PROGRAM_SERVER=0``); ``rlimits``: resource limits of the new process; ``default_signals``: signals
    it starts with at their default handling and unblocked, whatever this process does with them (a shell's start)."""
    if not served():
        if rlimits or default_signals:
            kwargs["preexec_fn"] = _set_limits(rlimits or {}, default_signals)
        return subprocess.Popen(args, **kwargs)
    return ServedProcess(args, rlimits=rlimits, default_signals=default_signals, **kwargs)


def run(args, *, input=None, capture_output=False, timeout=None, check=False, **kwargs):   # noqa: A002
    """``subprocess.run`` with this module's ``Popen``."""
    if capture_output:
        kwargs["stdout"] = kwargs["stderr"] = PIPE
    if input is not None:
        kwargs["stdin"] = PIPE
    with Popen(args, **kwargs) as process:
        try:
            out, err = process.communicate(input, timeout=timeout)
        except TimeoutExpired:
            process.kill()
            process.communicate()
            raise
        except BaseException:
            process.kill()
            raise
        code = process.poll()
    if check and code:
        raise CalledProcessError(code, process.args, output=out, stderr=err)
    return CompletedProcess(process.args, code, out, err)


def _set_limits(rlimits, default_signals=()):
    def set_limits():
        import resource
        for which, limit in rlimits.items():
            resource.setrlimit(which, limit)
        for s in default_signals:
            signal.signal(s, signal.SIG_DFL)
        if default_signals:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, set(default_signals))
    return set_limits


class ServedProcess(subprocess.Popen):
    """A ``subprocess.Popen`` whose process the program server forks; waiting for it is reading its wait status."""

    def __init__(self, args, *, rlimits=None, default_signals=(), **kwargs):
        self._rlimits = dict(rlimits or {})
        self._default_signals = {signal.Signals(s) for s in default_signals}
        self._status = None         # the status socket (set in _execute_child)
        self._served_status = None
        self.cpu = None             # user and system CPU seconds of the process and its waited-for descendants
        super().__init__(args, **kwargs)

    def _execute_child(self, args, executable, preexec_fn, close_fds, pass_fds, cwd, env, startupinfo,
                       creationflags, shell, p2cread, p2cwrite, c2pread, c2pwrite, errread, errwrite,
                       restore_signals, gid, gids, uid, umask, start_new_session, *more):
        args = [os.fsdecode(a) for a in ([args] if isinstance(args, (str, bytes, os.PathLike)) else args)]
        process_group = more[0] if more else -1
        refused = [name for name, value in (("executable", executable), ("preexec_fn", preexec_fn),
                                            ("pass_fds", pass_fds), ("shell", shell), ("user", uid),
                                            ("group", gid), ("extra_groups", gids)) if value]
        if refused or not close_fds:
            raise TypeError(f"program_server: {', '.join(refused) or 'close_fds=False'} cannot be served; "
                            "use subprocess")
        if len(args) < 3 or args[0] != sys.executable or args[1] not in ("-m", "-c"):
            raise TypeError(f"program_server serves [sys.executable, '-m'/'-c', ...] only, not {args[:2]}")
        env = dict(os.environ) if env is None else {os.fsdecode(k): os.fsdecode(v) for k, v in env.items()}
        blas = [name for name in BLAS_THREAD_VARIABLES if env.get(name, "1") != "1"]
        if blas:
            raise ValueError(f"program_server: {', '.join(blas)} is read when NumPy loads, which the server has "
                             "done with one thread; use subprocess")
        if umask < 0:
            umask = os.umask(0)
            os.umask(umask)
        ignored = {s for s in signal.valid_signals() if signal.getsignal(s) == signal.SIG_IGN} - self._default_signals
        if restore_signals:
            ignored -= {getattr(signal, n) for n in ("SIGPIPE", "SIGXFZ", "SIGXFSZ") if hasattr(signal, n)}
        request = {"argv": args[1:], "env": env, "cwd": os.fspath(cwd) if cwd is not None else os.getcwd(),
                   "umask": umask, "new_session": bool(start_new_session), "process_group": process_group,
                   "ignored": sorted(ignored),
                   "mask": sorted(signal.pthread_sigmask(signal.SIG_BLOCK, []) - self._default_signals),
                   "rlimits": self._rlimits}
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        stdio = [fd if fd != -1 else k for k, fd in enumerate((p2cread, c2pwrite, errwrite))]
        try:
            _server_for(env).send(request, stdio + [theirs.fileno()])
        except BaseException:
            ours.close()
            raise
        finally:
            theirs.close()
        self._status = ours
        pid, error = None, None
        while pid is None or error is None:      # the server's word of the fork, the child's of its set-up
            msg = ours.recv(_MSG)
            if not msg:
                raise RuntimeError("program_server: the server ended while starting a command (see "
                                   f"{_server_for(env).log})")
            if msg[:1] == b"P":
                pid = struct.unpack("q", msg[1:])[0]
            elif msg[:1] == b"R":
                error = ()
            elif msg[:1] == b"E":
                error = pickle.loads(msg[1:])
            elif msg[:1] == b"S":       # the child is gone (its set-up failed)
                self._served_status = struct.unpack("i", msg[1:5])[0]
                self._reaped()
        self.pid = pid
        self._child_created = True
        self._close_pipe_fds(p2cread, p2cwrite, c2pread, c2pwrite, errread, errwrite)
        if error:
            self.wait()
            raise OSError(*error)

    def _served_waitpid(self, pid, flags):
        if self._served_status is None:
            if flags & os.WNOHANG:
                ready, _, _ = select.select([self._status], [], [], 0)
                if not ready:
                    return 0, 0
            msg = self._status.recv(_MSG)
            if not msg:
                raise RuntimeError(f"program_server: the server ended before process {pid}")
            self._served_status = struct.unpack("i", msg[1:5])[0]
            self._reaped()
        return pid, self._served_status

    def _reaped(self):
        """The server reaps the process (its pid is free from now on, as after waitpid) and tells its CPU time."""
        try:
            self._status.send(b"W")
            msg = self._status.recv(_MSG)
        except OSError:         # a server that has stopped reaped its children itself
            msg = b""
        if msg[:1] == b"U":
            self.cpu = list(struct.unpack("dd", msg[1:]))
        self._status.close()

    def _internal_poll(self, _deadstate=None, **_):
        return super()._internal_poll(_deadstate, _waitpid=self._served_waitpid)

    def _try_wait(self, wait_flags):
        return self._served_waitpid(self.pid, wait_flags)


class _Server:
    """One program server: its process, and the socket commands are sent on (its end of file stops the server)."""

    def __init__(self, env: dict):
        fd, name = tempfile.mkstemp(prefix="program-server-", suffix=".log")      # what the server says if it fails
        os.close(fd)
        self.log = Path(name)
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        with open(self.log, "wb") as log:
            self.process = subprocess.Popen([sys.executable, "-c", _BOOT, __file__, str(theirs.fileno())], env=env,
                                            cwd="/", stdin=DEVNULL, stdout=log, stderr=log, pass_fds=[theirs.fileno()],
                                            start_new_session=True)
        theirs.close()
        self.sock = ours
        self.lock = threading.Lock()
        if ours.recv(_MSG) != b"ready":
            self.process.wait()
            said = self.log.read_text()[-2000:]
            self.log.unlink()
            raise RuntimeError(f"program_server: the server did not start: {said}")

    def send(self, request: dict, fds: list[int]):
        with self.lock:
            socket.send_fds(self.sock, [pickle.dumps(request)], fds)

    def stop(self):
        self.sock.close()
        self.process.wait()
        if self.process.returncode == 0:
            self.log.unlink(missing_ok=True)


_servers: dict[tuple, _Server] = {}
_servers_lock = threading.Lock()


def _start_signature(env: dict) -> tuple:
    return tuple(sorted((k, v) for k, v in env.items() if k.startswith(START_PREFIXES) or k in START_NAMES))


def _server_for(env: dict) -> _Server:
    key = _start_signature(env)
    with _servers_lock:
        if key not in _servers:
            _servers[key] = _Server(env)
        return _servers[key]


def stop_servers():
    """Stops every server and waits for it (tests/conftest.py at the session's end): their children's CPU is counted
    with this process's, and none is left running."""
    with _servers_lock:
        while _servers:
            _servers.popitem()[1].stop()


# -- the server's side -----------------------------------------------------------------------------------------
_BOOT = ("import importlib.util as u, sys; s = u.spec_from_file_location('program_server', sys.argv[1])\n"
         "m = u.module_from_spec(s); s.loader.exec_module(m); program = m.serve(int(sys.argv[2])); del u, s, m\n"
         "program()")


def _preload():
    """What a ``cosim-master`` command imports before it runs (pyarrow aside: it starts a thread when it loads), and
    the plotting library, which no plug-in registers anything with."""
    import gc
    import importlib

    import master.cli as cli
    cli._numpy_single_threaded()            # NumPy as the CLI loads it: OpenBLAS on one thread
    for command in ("run", "campaign", "report"):
        for name in cli.COMMAND_MODULES.get(command, ()):
            importlib.import_module(name)
    import fmpy.fmi2  # noqa: F401 - what a run loads its FMUs with
    # what a UAV run's map is drawn with (a Figure on the Agg canvas, uavstudy/outputs.py: no backend chosen); it
    # reads its configuration and font cache when it loads (the MPL*/HOME/XDG_* variables of START_*)
    import matplotlib.backends.backend_agg  # noqa: F401
    import matplotlib.figure  # noqa: F401
    threads = len(os.listdir("/proc/self/task"))
    if threads != 1:
        raise RuntimeError(f"the program server has {threads} threads after its imports; a fork would copy one")
    gc.collect()
    gc.freeze()         # as the CLI does before it forks: the children do not copy pages a collection would write


def serve(control_fd: int):
    """The server's loop; returns only in a forked child: the program to run. A child that has ended stays a zombie
    (its pid and process group taken) until the test waits for it, as a child of the test would."""
    control = socket.socket(fileno=control_fd)
    _preload()
    control.send(b"ready")
    running: dict[int, tuple[int, int]] = {}       # pidfd -> (pid, status socket)
    ended: dict[int, int] = {}                      # status socket -> pid, until the test waits for it
    while True:
        ready, _, _ = select.select([control_fd, *running, *ended], [], [])
        for fd in ready:
            if fd in running:               # ended: the test is told its wait status; its poll or wait reaps it
                pid, status = running.pop(fd)
                os.close(fd)
                _send(status, b"S" + struct.pack("i", _wait_status(os.waitid(os.P_PID, pid,
                                                                               os.WEXITED | os.WNOWAIT))))
                ended[status] = pid
            elif fd in ended:               # the test waited (or dropped its handle)
                os.read(fd, 1)              # (a socket closed with its word unread would lose the answer)
                _reap(ended.pop(fd), fd)
            else:
                msg, fds, _, _ = socket.recv_fds(control, _MSG, 4)
                if not msg:         # the test process is gone or done: so is every command it started
                    for pid, status in running.values():
                        _kill(pid)
                        _send(status, b"S" + struct.pack("i", os.waitpid(pid, 0)[1]))
                    for status, pid in ended.items():
                        _reap(pid, status)
                    os._exit(0)
                request = pickle.loads(msg)
                pid = os.fork()
                if pid == 0:
                    return _become(request, fds, control)
                for fd_ in fds[:3]:
                    os.close(fd_)
                running[os.pidfd_open(pid)] = (pid, fds[3])
                _send(fds[3], b"P" + struct.pack("q", pid))


def _wait_status(info) -> int:
    """waitid's answer as the status word waitpid gives."""
    if info.si_code == os.CLD_EXITED:
        return (info.si_status & 0xFF) << 8
    return info.si_status | (0x80 if info.si_code == os.CLD_DUMPED else 0)


def _reap(pid: int, status: int):
    _, _, usage = os.wait4(pid, 0)
    _send(status, b"U" + struct.pack("dd", usage.ru_utime, usage.ru_stime))
    os.close(status)


def _send(fd: int, data: bytes):
    try:
        os.write(fd, data)
    except OSError:         # the test dropped its handle: nobody is waiting for the word
        pass


def _kill(pid: int):
    try:
        os.kill(pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def _become(request: dict, fds: list[int], control: socket.socket):
    """In the forked child: the process as exec would have started the program; returns the program to run."""
    status = fds[3]
    try:
        if request["new_session"]:
            os.setsid()
        elif request["process_group"] >= 0:
            os.setpgid(0, request["process_group"])
        _signals_as_at_start(request["ignored"], request["mask"])
        control.detach()
        for k, fd in enumerate(fds[:3]):
            os.dup2(fd, k)
        for fd in os.listdir("/proc/self/fd"):
            if int(fd) > 2 and int(fd) != status:
                try:
                    os.close(int(fd))
                except OSError:
                    pass
        import resource
        for which, limit in request["rlimits"].items():
            resource.setrlimit(which, limit)
        os.umask(request["umask"])
        os.chdir(request["cwd"])
        for environ in (os.environ, os.environb):
            environ.clear()
        os.environ.update(request["env"])
        os.environb.update({os.fsencode(k): os.fsencode(v) for k, v in request["env"].items()})
        import time
        time.tzset()
        tempfile.tempdir = None                 # decided from TMPDIR at its first use, as in a new process
        program = _program(request["argv"])
        _streams_as_at_start()
    except OSError as exc:
        _send(status, b"E" + pickle.dumps((exc.errno, exc.strerror, exc.filename)))
        os._exit(255)
    except BaseException as exc:        # noqa: BLE001 - the test is told, and this process must not serve on
        _send(status, b"E" + pickle.dumps((0, f"program_server: {exc!r}")))
        os._exit(255)
    _send(status, b"R")
    os.close(status)
    return program


def _signals_as_at_start(ignored, mask):
    for s in signal.valid_signals():
        if s in (signal.SIGKILL, signal.SIGSTOP):
            continue
        try:
            signal.signal(s, signal.SIG_IGN if s in ignored else signal.SIG_DFL)
        except (OSError, ValueError):       # the C library's own real-time signals
            pass
    for name in ("SIGPIPE", "SIGXFZ", "SIGXFSZ"):      # what Python's start does
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_IGN)
    if signal.SIGINT not in ignored:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def _streams_as_at_start():
    """New ``sys.stdin/stdout/stderr`` on descriptors 0-2, as Python makes them: stdout line-buffered only on a
    terminal, stderr always, with backslashreplace; both unbuffered under ``-u``/``PYTHONUNBUFFERED`` (as the
    server's own are)."""
    import io
    unbuffered = isinstance(sys.__stdout__.buffer, io.FileIO)
    made = []
    for fd, old, mode in ((0, sys.__stdin__, "rb"), (1, sys.__stdout__, "wb"), (2, sys.__stderr__, "wb")):
        raw = io.FileIO(fd, mode, closefd=False)
        if fd == 0:
            binary = io.BufferedReader(raw)
        else:
            binary = raw if unbuffered else io.BufferedWriter(raw)
        made.append(io.TextIOWrapper(binary, encoding=old.encoding, errors=old.errors,
                                     line_buffering=not unbuffered and (fd == 2 or raw.isatty()),
                                     write_through=unbuffered))
    sys.stdin, sys.stdout, sys.stderr = made
    sys.__stdin__, sys.__stdout__, sys.__stderr__ = made


def _program(argv: list[str]):
    """``-m MODULE args`` or ``-c CODE args``: sys.argv, sys.path[0] and __main__ as the interpreter sets them."""
    import importlib
    import types
    option, target, rest = argv[0], argv[1], argv[2:]
    sys.path_importer_cache.pop("", None)
    importlib.invalidate_caches()
    main = types.ModuleType("__main__")
    sys.modules["__main__"] = main
    if option == "-m":
        import runpy
        sys.argv = [target, *rest]        # runpy puts the module's file in place of the name
        sys.path[0] = os.getcwd()
        # the module runs as __main__ only, as with -m (the server imported it as itself); whoever imports it by its
        # name then gets a module of its own, as in a new process
        package, _, name = target.rpartition(".")
        if sys.modules.pop(target, None) is not None and package in sys.modules:
            vars(sys.modules[package]).pop(name, None)
        return lambda: runpy._run_module_as_main(target)
    sys.argv = ["-c", *rest]
    sys.path[0] = ""
    code = compile(target, "<string>", "exec")
    return lambda: exec(code, main.__dict__)
