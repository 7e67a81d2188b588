"""What a sweep on a cluster needs beyond a local one: the system file sent to the workers, and a check that
the scheduler address answers as a dask scheduler.

A system given as a file (``.ssp``, ``.fmu``, ``.py``) is read by the client and sent to the workers (a
:class:`SystemFile`: name, SHA-256 and bytes, in a task of its own through the scheduler, which computes it again
when a worker that held it is lost), so workers that share no disk with the
client run it: each worker process writes it once per content hash into its temporary folder
(``pressdrive-sweep/<hash>/<name>``) and loads it from there.  A drive name (``feeder_gto52``) is sent as the
name: every worker has the toolkit and builds its FMUs itself.

:func:`check_scheduler` connects to ``--scheduler ADDRESS`` before the client does and reads the greeting a
dask scheduler sends first (an 8-byte length and a handshake of a few hundred bytes naming its pickle
protocol): anything else listening there (a web server, a database) is one line within the connect timeout,
where dask's own client would wait for minutes or try to allocate the exabytes the first bytes spell.
"""
from __future__ import annotations

import hashlib
import os
import socket
import struct
import tempfile
from dataclasses import dataclass
from pathlib import Path

from harness.studies.sweep_checks import SweepError

SHIPPED_SUFFIXES = (".ssp", ".fmu", ".py")
_GREETING_LIMIT = 1 << 20   # a dask handshake is a few hundred bytes; more is some other service's data


@dataclass(frozen=True)
class SystemFile:
    """A system file as the workers receive it."""
    name: str
    digest: str
    data: bytes

    def local_path(self) -> Path:
        """The file on this machine, written once per content hash (atomically: two workers of one host may
        write it at the same time)."""
        folder = Path(tempfile.gettempdir()) / "pressdrive-sweep" / self.digest[:32]
        path = folder / self.name
        if not path.is_file():
            folder.mkdir(parents=True, exist_ok=True)
            tmp = folder / f".{self.name}.{os.getpid()}.part"
            tmp.write_bytes(self.data)
            os.replace(tmp, path)
        return path


_LOCAL: dict[str, Path] = {}   # digest -> path, per worker process


def payload(system: SystemFile) -> SystemFile:
    """The task that hands the system file to the points on a cluster (its bytes live in the task itself)."""
    return system


def shipped(system: str) -> str | SystemFile:
    """``system`` as it goes to the workers: a :class:`SystemFile` for an existing ``.ssp``/``.fmu``/``.py``
    file, the name itself otherwise (a drive; an ``.ssd`` refers to files beside it and is sent as typed)."""
    path = Path(str(system))
    if path.suffix.lower() in SHIPPED_SUFFIXES and path.is_file():
        data = path.read_bytes()
        return SystemFile(path.name, hashlib.sha256(data).hexdigest(), data)
    return str(system)


def system_on_worker(system: str | SystemFile) -> str:
    """What a worker loads: the local copy of a shipped file (cached per content hash), else the name."""
    if not isinstance(system, SystemFile):
        return system
    path = _LOCAL.get(system.digest)
    if path is None or not path.is_file():
        path = _LOCAL[system.digest] = system.local_path()
    return str(path)


def connect_timeout() -> float:
    """dask's connect timeout (``distributed.comm.timeouts.connect``), in seconds."""
    import dask
    import distributed  # noqa: F401 (its import registers the distributed.* defaults in dask's configuration)
    from dask.utils import parse_timedelta

    return float(parse_timedelta(dask.config.get("distributed.comm.timeouts.connect", default="30s"),
                                 default="seconds"))


def check_scheduler(address: str, timeout: float | None = None) -> None:
    """One line (:class:`SweepError`) unless a dask scheduler greets at ``address`` within ``timeout``
    (default: :func:`connect_timeout`).  Addresses of other protocols (``tls://``, ``inproc://``) are left to
    dask."""
    timeout = connect_timeout() if timeout is None else timeout
    scheme, _, rest = address.rpartition("://")
    if scheme not in ("", "tcp"):
        return
    host, _, port = rest.rpartition(":")
    host = host.strip("[]") or "localhost"
    where = f"--scheduler {address}"
    try:
        port_number = int(port)
    except ValueError:
        raise SweepError(f"{where}: give HOST:PORT or tcp://HOST:PORT (the scheduler's address)") from None
    try:
        with socket.create_connection((host, port_number), timeout=timeout) as s:
            s.settimeout(timeout)
            head = _read(s, 8)
            (size,) = struct.unpack("<Q", head)
            if not 0 < size <= _GREETING_LIMIT:
                raise SweepError(f"{where}: the service there is no dask scheduler (its first bytes "
                                 f"{head!r} are no dask greeting)")
            body = _read(s, size)
    except SweepError:
        raise
    except socket.timeout:
        raise SweepError(f"{where}: no dask scheduler greeted within {timeout:g} s (the connect timeout, dask "
                         f"setting distributed.comm.timeouts.connect)") from None
    except (EOFError, ConnectionResetError, BrokenPipeError):
        raise SweepError(f"{where}: the service there closed the connection without a dask greeting") from None
    except OSError as e:
        raise SweepError(f"{where}: cannot connect: {e.strerror or e}") from None
    if b"pickle-protocol" not in body:
        raise SweepError(f"{where}: the service there is no dask scheduler (its greeting holds no dask "
                         f"handshake)")


def _read(s: socket.socket, n: int) -> bytes:
    data = b""
    while len(data) < n:
        chunk = s.recv(min(n - len(data), 65536))
        if not chunk:
            raise EOFError
        data += chunk
    return data


__all__ = ["SystemFile", "shipped", "payload", "system_on_worker", "check_scheduler", "connect_timeout"]
