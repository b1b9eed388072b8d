"""Preloaded by the fork server of a run's (or preview worker's) process tree, nowhere else: the
fork server and the layer workers it forked end as soon as the tree's leader — their parent's
process — has gone without ending them (killed: by the kernel with the server killed -9
(PR_SET_PDEATHSIG), or by the OOM killer). Python's fork server would otherwise live on: each
worker holds the fork server's "alive" pipe, and each worker waits on its own task queue, whose
write end it holds too; the workers die with the fork server, so neither ever ends.

The leader names its process group in WAAMFLOW_TREE_PGID (tree_memory._detach_from_server);
without it (a fork server of the server's own, with run_memory_mb 0) nothing is watched.
"""

from __future__ import annotations

import os
import signal
import threading
import time

POLL_S = 0.25


def _watch(pgid: int, parent: int) -> None:
    while True:
        if os.getppid() != parent:  # reparented: the leader has gone
            try:
                os.killpg(pgid, signal.SIGKILL)  # the fork server (this process) and its workers
            except OSError:
                pass
            return
        time.sleep(POLL_S)


def _start() -> None:
    want = os.environ.get("WAAMFLOW_TREE_PGID", "")
    if not want.isdigit() or os.getpgid(0) != int(want) or os.getpid() == int(want):
        return  # not in a run's tree (or the leader itself): leave the group alone
    threading.Thread(target=_watch, args=(int(want), os.getppid()), name="waamflow-tree-guard", daemon=True).start()


_start()
