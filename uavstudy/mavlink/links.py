"""The transports of a MAVLink stream, in pymavlink's address forms, without blocking the simulation.

``udpout:HOST:PORT`` sends to a ground station listening there (QGroundControl and MAVProxy listen on
14550) and takes its replies on the same socket; ``udpin:HOST:PORT`` listens and answers whoever sent last;
``tcpin:HOST:PORT`` listens for any number of ground stations; ``tcp:HOST:PORT`` connects to one.

Every socket is non-blocking: a ground station that is slow, silent or gone costs the run nothing but a
warning (logger ``cosim_master``), and the run goes on.  Messages are sent in datagrams of whole messages
(at most ``DATAGRAM`` bytes, below a network's MTU); a TCP peer that cannot keep up with ``TCP_BACKLOG``
bytes is dropped.
"""
from __future__ import annotations

import errno
import logging
import select
import socket
import time

from master.errors import CosimError

log = logging.getLogger("cosim_master")

FORMS = ("udpout", "udpin", "tcpin", "tcp")
DATAGRAM = 1400
TCP_BACKLOG = 4 << 20
SILENT_S = 5.0            # a ground station heard before and silent this long (wall clock) is reported gone


def parse_url(url: str) -> tuple[str, str, int]:
    """(form, host, port) of a pymavlink address; a CosimError naming ``--mavlink`` otherwise."""
    form, _, rest = str(url).partition(":")
    host, _, port = rest.rpartition(":")
    if form not in FORMS or not host or not port:
        raise CosimError(f"{url!r} is not a MAVLink address: expected {', '.join(f + ':HOST:PORT' for f in FORMS)}",
                         element="--mavlink")
    try:
        number = int(port)
    except ValueError:
        number = -1
    if not 0 <= number <= 65535:
        raise CosimError(f"{url!r}: port {port!r} is not a number from 0 to 65535", element="--mavlink")
    return form, host, number


def _address(url, host, port):
    try:
        return socket.getaddrinfo(host, port, socket.AF_INET)[0][4]
    except socket.gaierror as exc:
        raise CosimError(f"{url!r}: unknown host {host!r} ({exc.strerror})", element="--mavlink") from None


def open_link(url: str) -> "Link":
    form, host, port = parse_url(url)
    return {"udpout": UdpOut, "udpin": UdpIn, "tcpin": TcpIn, "tcp": TcpOut}[form](url, _address(url, host, port))


class Link:
    """One address: ``send`` a list of encoded messages, ``receive`` the bytes that arrived (by peer)."""

    def __init__(self, url: str, address):
        self.url, self.address = url, address
        self.sent = self.dropped = 0
        self.heard_at: dict = {}           # peer -> wall time of its last bytes
        self.gone: set = set()
        # a forwarded firmware's stream (forward.py): its end is the end of its vehicle, which the run reports
        # itself (a SITL is stopped before the stream is), so no ground-station warning for it
        self.quiet = False

    def _fail(self, exc: OSError, doing: str):
        why = exc.strerror or str(exc)
        if exc.errno == errno.EADDRINUSE:
            why = "the address is in use (another program, or another run, has it)"
        raise CosimError(f"{self.url}: cannot {doing}: {why}", element="--mavlink") from None

    @staticmethod
    def datagrams(messages: list[bytes]):
        """Whole messages packed into datagrams of at most DATAGRAM bytes."""
        out, size = [], 0
        for m in messages:
            if size and size + len(m) > DATAGRAM:
                yield b"".join(out)
                out, size = [], 0
            out.append(m)
            size += len(m)
        if out:
            yield b"".join(out)

    def heard(self, peer) -> None:
        self.heard_at[peer] = time.monotonic()
        if peer in self.gone:
            self.gone.discard(peer)
            log.warning("--mavlink %s: ground station %s is back", self.url, _show(peer))

    def check_silence(self) -> None:
        now = time.monotonic()
        for peer, at in self.heard_at.items():
            if peer not in self.gone and now - at > SILENT_S:
                self.gone.add(peer)
                log.warning("--mavlink %s: ground station %s silent for %g s (gone?); the run goes on",
                            self.url, _show(peer), SILENT_S)

    def send(self, messages: list[bytes]) -> None:
        raise NotImplementedError

    def filenos(self) -> list[int]:
        """The sockets to wait on for input."""
        raise NotImplementedError

    def receive(self) -> list[tuple[object, bytes]]:
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError


def _show(peer) -> str:
    return f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) else str(peer)


class _Udp(Link):
    def __init__(self, url, address):
        super().__init__(url, address)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setblocking(False)
        self.peers: list = []

    def send(self, messages):
        for data in self.datagrams(messages):
            for peer in self.peers:
                try:
                    self.sock.sendto(data, peer)
                    self.sent += 1
                except OSError:       # nobody listening (ICMP unreachable), a full buffer: the next one goes
                    self.dropped += 1

    def receive(self):
        got = []
        while True:
            try:
                data, peer = self.sock.recvfrom(65536)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:           # an ICMP error of an earlier datagram: nothing to read
                break
            self.heard(peer)
            self._learn(peer)
            got.append((peer, data))
        return got

    def _learn(self, peer):
        pass

    def filenos(self):
        return [self.sock.fileno()]

    def close(self):
        self.sock.close()


class UdpOut(_Udp):
    def __init__(self, url, address):
        super().__init__(url, address)
        self.peers = [address]


class UdpIn(_Udp):
    def __init__(self, url, address):
        super().__init__(url, address)
        try:
            self.sock.bind(address)
        except OSError as exc:
            self.sock.close()
            self._fail(exc, "listen")

    def _learn(self, peer):
        if peer not in self.peers:
            self.peers.append(peer)


class _Tcp(Link):
    def __init__(self, url, address):
        super().__init__(url, address)
        self.clients: dict = {}           # socket -> (peer, pending bytes)

    def _add(self, sock, peer):
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.clients[sock] = [peer, bytearray()]

    def _drop(self, sock, why):
        peer = self.clients.pop(sock)[0]
        self.heard_at.pop(peer, None)
        sock.close()
        if not self.quiet:
            log.warning("--mavlink %s: ground station %s %s; the run goes on", self.url, _show(peer), why)

    def send(self, messages):
        data = b"".join(messages)
        for sock, entry in list(self.clients.items()):
            pending = entry[1]
            pending += data
            try:
                n = sock.send(pending)
                del pending[:n]
                self.sent += 1
            except (BlockingIOError, InterruptedError):
                pass
            except OSError as exc:
                self._drop(sock, f"disconnected ({exc.strerror or exc})")
                continue
            if len(pending) > TCP_BACKLOG:
                self._drop(sock, f"cannot keep up ({len(pending)} bytes waiting): disconnected")

    def filenos(self):
        return [sock.fileno() for sock in self.clients]

    def receive(self):
        got = []
        for sock, (peer, _) in list(self.clients.items()):
            try:
                data = sock.recv(65536)
            except (BlockingIOError, InterruptedError):
                continue
            except OSError as exc:
                self._drop(sock, f"disconnected ({exc.strerror or exc})")
                continue
            if not data:
                self._drop(sock, "disconnected")
                continue
            self.heard(peer)
            got.append((peer, data))
        return got

    def close(self):
        for sock in list(self.clients):
            sock.close()
        self.clients.clear()


class TcpIn(_Tcp):
    def __init__(self, url, address):
        super().__init__(url, address)
        self.server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self.server.bind(address)
            self.server.listen(8)
        except OSError as exc:
            self.server.close()
            self._fail(exc, "listen")
        self.server.setblocking(False)

    def receive(self):
        while select.select([self.server], [], [], 0)[0]:
            try:
                sock, peer = self.server.accept()
            except OSError:
                break
            self._add(sock, peer)
        return super().receive()

    def filenos(self):
        return [self.server.fileno(), *super().filenos()]

    def close(self):
        super().close()
        self.server.close()


class TcpOut(_Tcp):
    def __init__(self, url, address):
        super().__init__(url, address)
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.settimeout(5.0)
        try:
            sock.connect(address)
        except OSError as exc:
            sock.close()
            self._fail(exc, "connect")
        self._add(sock, address)
