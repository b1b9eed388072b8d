"""One memory budget for a whole process tree (a run, or the preview worker, with its layer workers,
fork server and resource tracker): `run_memory_mb` counted over the tree, not per process.

How it is enforced depends on the machine (`memory_mode()` says which applies):

- **cgroup v2** — when the server's own cgroup is on a cgroup2 mount, writable, and delegates the
  `memory` controller to its children (`memory` in its `cgroup.subtree_control`), each tree gets a
  child cgroup `waamflow-<name>` with `memory.max` = the budget; the kernel ends the tree's
  allocations there (its OOM killer picks a process of the tree, never the server) and
  `memory.events` tells that it happened.
- **watchdog** — otherwise: the server samples the tree's private memory (USS:
  `Private_Clean + Private_Dirty + Swap` of `/proc/<pid>/smaps_rollup`, so the pages a forked run
  still shares with the server are not charged to it) every `SAMPLE_S`, finds the tree's
  processes by process group every `RESCAN_S`, and kills the whole group when the sum is over the
  budget.

Both are Linux only; elsewhere runs execute in the server's process (see worker.RUN_PROCESSES).
"""

from __future__ import annotations

import logging
import math
import multiprocessing as mp
import os
import signal
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, ContextManager

log = logging.getLogger("waamflow.runs")

SAMPLE_S = 0.15  # how often the tree's memory is summed
RESCAN_S = 0.5  # how often its processes are looked up again (a full /proc scan: ~8 ms on a busy box)
CGROUP_PREFIX = "waamflow-"
TREE_GUARD = "waamflow.api.tree_guard"  # preloaded by a tree's fork server


def private_bytes(pid: int) -> int:
    """Memory only this process holds (USS + its swapped-out pages), bytes; 0 when it has gone."""
    try:
        with open(f"/proc/{pid}/smaps_rollup", "rb") as f:
            total = 0
            for line in f:
                if line.startswith((b"Private_Clean:", b"Private_Dirty:", b"Swap:")):
                    total += int(line.split()[1]) * 1024
            return total
    except FileNotFoundError:
        pass
    except (OSError, ValueError, IndexError):
        return 0
    try:  # no smaps_rollup (old kernels): resident minus shared pages
        with open(f"/proc/{pid}/statm", "rb") as f:
            fields = f.read().split()
        return max(0, int(fields[1]) - int(fields[2])) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def group_pids(pgid: int) -> list[int]:
    """Living processes of the process group `pgid` (zombies excluded)."""
    out: list[int] = []
    try:
        names = os.listdir("/proc")
    except OSError:
        return out
    for name in names:
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", "rb") as f:
                stat = f.read()
        except OSError:
            continue
        rest = stat[stat.rfind(b")") + 2 :].split()  # after "pid (comm) ": state ppid pgrp ...
        if len(rest) > 2 and rest[0] != b"Z" and int(rest[2]) == pgid:
            out.append(int(name))
    return out


class TreeWatch:
    """The memory of one process group (the tree whose leader is `pgid`) against `budget` bytes.
    `check()` is cheap to call often: it samples at most every SAMPLE_S and returns the bytes
    used when over the budget (else None)."""

    def __init__(self, pgid: int, budget: int) -> None:
        self.pgid = pgid
        self.budget = budget
        self.pids: list[int] = [pgid]
        self.peak = 0
        self.processes = 1
        self._scanned = 0.0
        self._sampled = 0.0

    def used(self) -> int:
        now = time.monotonic()
        if now - self._scanned >= RESCAN_S:
            self._scanned = now
            self.pids = group_pids(self.pgid) or [self.pgid]
        total = sum(private_bytes(p) for p in self.pids)
        self.processes = len(self.pids)
        self.peak = max(self.peak, total)
        return total

    def check(self) -> int | None:
        if self.budget <= 0:
            return None
        now = time.monotonic()
        if now - self._sampled < SAMPLE_S:
            return None
        self._sampled = now
        used = self.used()
        return used if used > self.budget else None


def tree_limit_message(what: str, budget: int, used: int, processes: int, where: str = "") -> str:
    """The failure of a tree over its budget, naming the limit and how to raise it. The use is
    rounded up to the MB, so it never reads as equal to the budget it broke."""
    return (
        f"{what} used {math.ceil(used / 2**20)} MB of memory in {processes} process{'es' if processes != 1 else ''} "
        f"together{where}, more than {budget / 2**20:.0f} MB, its memory limit (run_memory_mb, for the run's "
        "whole process tree: the run and its layer workers): raise --run-memory-mb / WAAMFLOW_RUN_MEMORY_MB, "
        "or make the work smaller (fewer layers, a coarser mesh)"
    )


# ---- cgroup v2 ------------------------------------------------------------------------------------


def _own_cgroup_dir() -> Path | None:
    """This process's cgroup v2 directory, or None (no unified hierarchy mounted)."""
    try:
        rel = next(
            line[3:].strip() for line in Path("/proc/self/cgroup").read_text().splitlines() if line.startswith("0::")
        )
        mounts = [line.split() for line in Path("/proc/self/mounts").read_text().splitlines()]
    except (OSError, StopIteration):
        return None
    for fields in mounts:
        if len(fields) > 2 and fields[2] == "cgroup2":
            d = Path(fields[1]) / rel.lstrip("/")
            if d.is_dir():
                return d
    return None


def cgroup_parent(base: Path | None = None) -> tuple[Path | None, str]:
    """Where the server may create a child cgroup with `memory.max`, or None, and why (for the
    log and `memory_mode`)."""
    d = base if base is not None else _own_cgroup_dir()
    if d is None:
        return None, "no cgroup v2 hierarchy for this process"
    try:
        delegated = (d / "cgroup.subtree_control").read_text().split()
    except OSError:
        return None, f"{d}: no cgroup.subtree_control"
    if "memory" not in delegated:
        return None, f"{d}: the memory controller is not delegated to child cgroups (cgroup.subtree_control)"
    if not os.access(d, os.W_OK):
        return None, f"{d}: not writable by this user"
    return d, f"cgroup v2 under {d}"


class Cgroup:
    """A child cgroup holding one process tree under `memory.max`."""

    def __init__(self, parent: Path, name: str, budget: int) -> None:
        self.path = parent / f"{CGROUP_PREFIX}{name}"
        self.path.mkdir(exist_ok=True)
        (self.path / "memory.max").write_text(str(budget))
        try:
            (self.path / "memory.oom.group").write_text("1")  # over the budget, the whole tree ends
        except OSError:
            pass
        try:
            (self.path / "memory.swap.max").write_text("0")
        except OSError:
            pass  # no swap accounting: memory.max alone

    def add(self, pid: int) -> None:
        (self.path / "cgroup.procs").write_text(str(pid))

    def oom_killed(self) -> int:
        """Processes of the tree the kernel killed for memory.max."""
        try:
            for line in (self.path / "memory.events").read_text().splitlines():
                key, _, value = line.partition(" ")
                if key == "oom_kill":
                    return int(value)
        except (OSError, ValueError):
            pass
        return 0

    def peak(self) -> int:
        for name in ("memory.peak", "memory.current"):
            try:
                return int((self.path / name).read_text())
            except (OSError, ValueError):
                continue
        return 0

    def remove(self) -> None:
        try:
            self.path.rmdir()  # empty once every process of the tree has ended
        except OSError:
            pass


def memory_mode() -> str:
    """Which enforcement applies on this machine: 'cgroup v2 under …' or 'watchdog (…)'."""
    parent, why = cgroup_parent()
    return why if parent is not None else f"watchdog ({why})"


# ---- process trees ------------------------------------------------------------------------------


def _vm_bytes() -> int:
    """The process's address space now (VmSize), bytes."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def _detach_from_server() -> None:
    """In a run's process, right after the fork: die with the server (kill -9 included), leave
    Ctrl-C and SIGTERM to it, and start a fork server of its own for the layer workers (the
    server's would fork them outside this process's memory limit)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    from multiprocessing import forkserver

    fs = forkserver._forkserver  # the module's functions are bound to this instance: reset it in place
    fd = getattr(fs, "_forkserver_alive_fd", None)
    if fd is not None:
        try:
            os.close(fd)  # the server's fork server must not wait for this process to end
        except OSError:
            pass
    vars(fs).update(
        _forkserver_address=None,
        _forkserver_alive_fd=None,
        _forkserver_pid=None,
        _inherited_fds=None,
        _lock=threading.Lock(),
    )
    # its fork server ends with this process, even killed (tree_guard.py)
    os.environ["WAAMFLOW_TREE_PGID"] = str(os.getpgid(0))
    preload = fs.set_forkserver_preload

    def preload_with_guard(modules: list[str]) -> None:
        preload([TREE_GUARD, *[m for m in modules if m != TREE_GUARD]])

    forkserver.set_forkserver_preload = preload_with_guard  # type: ignore[assignment]
    preload_with_guard(list(getattr(fs, "_preload_modules", None) or []))


def _kill_group(proc) -> None:
    """SIGKILL to a run's process group (the run, its fork server, its layer workers)."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError, OSError):
        try:
            proc.kill()
        except (OSError, ValueError, AttributeError):
            pass


_CGROUP: list[Path | None] = []  # where the server creates the trees' cgroups (looked up once)


def _cgroup_parent() -> Path | None:
    if not _CGROUP:
        parent, why = cgroup_parent()
        log.info("run memory limit (run_memory_mb) per process tree: %s", why if parent else f"watchdog ({why})")
        _CGROUP.append(parent)
    return _CGROUP[0]


@dataclass
class Tree:
    """A process tree under the run memory limit: its leader (the leader of its process group),
    its cgroup where one could be made, else the watchdog's sampling of the group."""

    proc: Any
    watch: TreeWatch
    cgroup: Cgroup | None
    over_by: int = 0  # bytes used when the watchdog found the tree over its budget

    def over(self) -> int | None:
        """Bytes used when over the budget (the group is killed), else None."""
        used = self.watch.check()
        if used is not None:
            self.over_by = used
            self.kill()
        return used

    def out_of_memory(self) -> bool:
        """The tree went over its budget (the watchdog's kill, or the kernel's in its cgroup)."""
        return bool(self.over_by) or (self.cgroup is not None and self.cgroup.oom_killed() > 0)

    def kill(self) -> None:
        _kill_group(self.proc)

    def end(self, patient: bool = False) -> None:
        """Everything left of the tree ends now (after a moment to end by itself if `patient`)."""
        if patient:
            self.proc.join(timeout=0.2)
        self.kill()
        self.proc.join(timeout=5.0)
        if self.cgroup is not None:
            for _ in range(20):  # empty once the killed processes are reaped
                if not group_pids(self.proc.pid):
                    break
                time.sleep(0.05)
            self.cgroup.remove()


def start_tree(
    quiet: Callable[[], ContextManager[Any]], budget: int, target: Callable[..., None], args: tuple, name: str
) -> Tree:
    """Fork `target(*args)` as the leader of a new process tree under `budget` bytes (forked
    within `quiet()`: see RunManager._quiet_sqlite)."""
    parent = _cgroup_parent()
    cg = None
    if parent is not None:
        try:
            cg = Cgroup(parent, name, budget)
        except OSError as e:
            log.warning("%s: no cgroup (%s): the watchdog keeps its memory limit", name, e)
    ctx = mp.get_context("fork")
    proc = ctx.Process(
        target=_tree_child,
        name=f"waamflow-{name}",
        args=(target, budget, str(cg.path) if cg is not None else None, args),
    )
    with quiet():
        proc.start()
    pid = proc.pid
    if pid is None:  # pragma: no cover - start() sets it
        raise RuntimeError(f"{name}: its process did not start")
    try:  # the tree's process group: the leader, its fork server and its workers end together
        os.setpgid(pid, pid)
    except OSError:
        pass  # it set it itself already (or has ended)
    return Tree(proc, TreeWatch(pid, 0 if cg is not None else budget), cg)


def close_inherited_network_sockets() -> int:
    """In a forked child: close the TCP sockets it inherited from the server (its listening
    socket, the browsers' connections, viser's). A long-lived child (a preview worker) holding a
    copy of a connection the server closes keeps it open: the client never sees the close, sends
    its next request on it and waits for good (a run's end never shown in the GUI, 1 e2e run in
    ~3). Pipes and socket pairs (AF_UNIX: the child's own channels) stay open. Returns how many
    were closed."""
    import socket

    closed = 0
    try:
        fds = [int(n) for n in os.listdir("/proc/self/fd")]
    except OSError:
        return 0
    for fd in fds:
        try:
            sock = socket.socket(fileno=fd)
        except OSError:
            continue  # not a socket (a pipe, a file) or already closed
        try:
            family = sock.family
        except OSError:
            sock.detach()
            continue
        if family in (socket.AF_INET, socket.AF_INET6):
            sock.close()
            closed += 1
        else:
            sock.detach()
    return closed


def _tree_child(target: Callable[..., None], budget: int, cgroup: str | None, args: tuple) -> None:
    """A tree's leader, right after the fork: a process group of its own, detached from the
    server, in its cgroup (before it starts anything), its address space capped at the budget."""
    import resource

    try:
        os.setpgid(0, 0)  # see _kill_group; the server sets it too
    except OSError:
        pass
    close_inherited_network_sockets()
    _detach_from_server()
    if cgroup is not None:
        try:
            Path(cgroup, "cgroup.procs").write_text(str(os.getpid()))
        except OSError as e:
            log.warning("not in cgroup %s (%s)", cgroup, e)
    try:
        resource.setrlimit(resource.RLIMIT_AS, (_vm_bytes() + budget, resource.RLIM_INFINITY))
    except (ValueError, OSError) as e:
        log.warning("%s: address-space limit not set (%s)", mp.current_process().name, e)
    target(*args)
