"""The program server's processes are the processes a real start makes: each program here runs both ways, forked by
the server and as a new interpreter (``subprocess``), and what it sees of itself must be the same (the real start is
the expectation), apart from what the server's docstring says a fork cannot show."""
import json
import os
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import program_server

REPO = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(REPO))


@pytest.fixture(autouse=True)
def served(monkeypatch):
    """The server is the subject here, also where COSIM_TEST_PROGRAM_SERVER=0 starts the other tests' commands anew."""
    monkeypatch.setenv("COSIM_TEST_PROGRAM_SERVER", "1")

# what a process can see of how it was started
SELF = r"""
import json, os, resource, signal, sys, tempfile
status = dict(line.split(":\t", 1) for line in open("/proc/self/status").read().splitlines() if ":\t" in line)
fds = sorted(int(f) for f in os.listdir("/proc/self/fd"))[:-1]       # the last: listdir's own
print(json.dumps({
    "argv": sys.argv, "path0": sys.path[0], "cwd": os.getcwd(), "env": dict(os.environ), "tmp": tempfile.gettempdir(),
    "umask": os.umask(0), "fds": fds, "session": os.getsid(0) == os.getpid(), "group": os.getpgid(0) == os.getpid(),
    "ignored": status["SigIgn"].strip(), "caught": status["SigCgt"].strip(), "blocked": status["SigBlk"].strip(),
    "sigint": repr(signal.getsignal(signal.SIGINT)), "fsize": resource.getrlimit(resource.RLIMIT_FSIZE),
    "stdio": [[f.isatty(), f.line_buffering, f.write_through, type(f.buffer).__name__, f.encoding, f.errors]
              for f in (sys.stdin, sys.stdout, sys.stderr)],
    "main": sorted(k for k in vars(sys.modules["__main__"]) if not k.startswith("__")),
}))
sys.exit(int(sys.argv[1]))
"""


def _both(args, **kwargs):
    """(served, real) results of the same command."""
    return [mod.run([sys.executable, *args], capture_output=True, text=True, timeout=60, **kwargs)
            for mod in (program_server, subprocess)]


def _seen(result):
    return json.loads(result.stdout)


def test_the_process_is_started_as_a_real_one(tmp_path):
    served, real = _both(["-c", SELF, "3", "x y"], env=dict(ENV, TMPDIR=str(tmp_path), ONLY_HERE="1",
                                                        OPENBLAS_NUM_THREADS="1"), cwd=tmp_path)
    assert served.returncode == real.returncode == 3, (served.stderr, real.stderr)
    assert _seen(served) == _seen(real)
    assert _seen(served)["env"]["ONLY_HERE"] == "1" and _seen(served)["tmp"] == str(tmp_path)
    assert _seen(served)["fds"] == [0, 1, 2]


def test_signals_ignored_or_blocked_in_the_caller_are_as_in_a_real_start():
    old = signal.signal(signal.SIGHUP, signal.SIG_IGN)      # as under nohup
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGUSR1})
    try:
        served, real = _both(["-c", SELF, "0"], env=ENV)
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGUSR1})
        signal.signal(signal.SIGHUP, old)
    assert _seen(served) == _seen(real)
    assert int(_seen(served)["ignored"], 16) >> (signal.SIGHUP - 1) & 1
    assert int(_seen(served)["blocked"], 16) == 1 << (signal.SIGUSR1 - 1)


def test_default_signals_start_as_a_preexec_fn_resetting_them_makes_them():
    """A test runner's worker may run with SIGINT ignored or blocked (exec keeps both): the campaign tests start
    their command as a shell would, SIGINT and SIGTERM handled by default."""
    def shell_like():
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.SIG_DFL)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})

    old = {s: signal.signal(s, signal.SIG_IGN) for s in (signal.SIGINT, signal.SIGHUP)}
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM, signal.SIGUSR1})
    try:
        served = program_server.run([sys.executable, "-c", SELF, "0"], capture_output=True, text=True, env=ENV,
                                    default_signals={signal.SIGINT, signal.SIGTERM})
        real = subprocess.run([sys.executable, "-c", SELF, "0"], capture_output=True, text=True, env=ENV,
                              preexec_fn=shell_like)
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM, signal.SIGUSR1})
        for s, handler in old.items():
            signal.signal(s, handler)
    assert _seen(served) == _seen(real)
    ignored, blocked = int(_seen(served)["ignored"], 16), int(_seen(served)["blocked"], 16)
    assert not ignored >> (signal.SIGINT - 1) & 1 and ignored >> (signal.SIGHUP - 1) & 1
    assert blocked == 1 << (signal.SIGUSR1 - 1)
    assert _seen(served)["sigint"] == repr(signal.default_int_handler)


def test_a_new_session_and_a_limit_and_a_umask(tmp_path):
    limit = (123_456, 123_456)
    old = os.umask(0o027)
    try:
        runs = [mod.run([sys.executable, "-c", SELF, "0"], capture_output=True, text=True, env=ENV,
                        start_new_session=True, **kw)
                for mod, kw in ((program_server, {"rlimits": {resource.RLIMIT_FSIZE: limit}}),
                                (subprocess, {"preexec_fn": lambda: resource.setrlimit(resource.RLIMIT_FSIZE, limit)}))]
    finally:
        os.umask(old)
    served, real = map(_seen, runs)
    assert served == real and served["session"] and served["group"] and served["umask"] == 0o027
    assert served["fsize"] == list(limit)
    assert not _seen(_both(["-c", SELF, "0"], env=ENV)[0])["session"]


def test_exits_by_status_signal_traceback_and_atexit_as_a_real_process():
    programs = {
        "exit": "import sys; sys.exit('a message')",
        "error": "def f():\n    raise ValueError('no')\nf()",
        "interrupt": "raise KeyboardInterrupt",
        "atexit": "import atexit, sys\natexit.register(lambda: print('at exit'))\nsys.stdout.write('buffered')",
        "_exit": "import atexit, os, sys\natexit.register(lambda: print('at exit'))\nsys.stdout.flush()\nos._exit(7)",
        "signal": "import os, signal; os.kill(os.getpid(), signal.SIGSEGV)",
    }
    for name, code in programs.items():
        served, real = _both(["-c", code], env=ENV)
        assert served.returncode == real.returncode, (name, served, real)
        assert served.stdout == real.stdout, name
        # the traceback's last line and the frames of the program itself (the server's start adds one line)
        assert served.stderr.splitlines()[-1:] == real.stderr.splitlines()[-1:], (name, served.stderr)
        assert [ln for ln in served.stderr.splitlines() if "<string>\", line" in ln and "<module>" not in ln] == \
            [ln for ln in real.stderr.splitlines() if "<string>\", line" in ln and "<module>" not in ln], name
    assert [r.returncode for r in _both(["-c", programs["interrupt"]], env=ENV)] == [-signal.SIGINT] * 2


def test_pipes_a_signal_and_a_timeout_as_subprocess():
    code = "import sys, time; print(sys.stdin.read().upper(), flush=True); time.sleep(60)"
    for mod in (program_server, subprocess):
        p = mod.Popen([sys.executable, "-c", code], env=ENV, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                      text=True, start_new_session=True)
        p.stdin.write("hello")
        p.stdin.close()
        assert p.stdout.readline() == "HELLO\n" and p.poll() is None
        with pytest.raises(subprocess.TimeoutExpired):
            p.wait(timeout=0.1)
        os.killpg(p.pid, signal.SIGTERM)
        assert p.wait(timeout=60) == -signal.SIGTERM, mod
        p.stdout.close()


def test_the_program_module_runs_as_main():
    served, real = _both(["-m", "master.cli", "--version"], env=ENV)
    assert served.returncode == real.returncode == 0 and served.stdout == real.stdout != ""
    assert served.stderr == real.stderr == ""         # (runpy warns when the module is imported already)


def test_what_it_cannot_serve_is_refused():
    for kwargs in ({"preexec_fn": os.getpid}, {"env": dict(ENV, OPENBLAS_NUM_THREADS="4")}, {"shell": True}):
        with pytest.raises((TypeError, ValueError), match="subprocess"):
            program_server.Popen([sys.executable, "-c", "pass"], **kwargs)
    with pytest.raises(TypeError, match="serves"):
        program_server.Popen(["true"])
    with pytest.raises(FileNotFoundError):
        program_server.Popen([sys.executable, "-c", "pass"], env=ENV, cwd="/no/such/folder")


def test_a_server_stops_with_its_caller_and_takes_its_commands_along():
    # a server of its own (another start-up variable), as the session's end or a killed pytest leaves it: the
    # socket closed
    env = dict(ENV, PYTHONHASHSEED="7")
    p = program_server.Popen([sys.executable, "-c", "import time; time.sleep(60)"], env=env)
    server = program_server._servers.pop(program_server._start_signature(env))
    server.stop()
    assert server.process.returncode == 0
    assert p.wait(timeout=60) == -signal.SIGKILL
    deadline = time.monotonic() + 60
    while Path(f"/proc/{p.pid}").exists() and time.monotonic() < deadline:
        time.sleep(0.01)
    assert not Path(f"/proc/{p.pid}").exists()


def test_an_ended_process_keeps_its_pid_and_group_until_it_is_waited_for():
    for mod in (program_server, subprocess):
        p = mod.Popen([sys.executable, "-c", "print('bye')"], env=ENV, stdout=subprocess.PIPE, text=True,
                      start_new_session=True)
        assert p.stdout.read() == "bye\n"
        p.stdout.close()
        deadline = time.monotonic() + 60
        while Path(f"/proc/{p.pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z":
            assert time.monotonic() < deadline, mod
            time.sleep(0.01)
        os.killpg(p.pid, 0)             # a zombie: its process group is still there, a signal to it no error
        assert p.wait(timeout=60) == 0
        with pytest.raises(ProcessLookupError):
            os.killpg(p.pid, 0)
