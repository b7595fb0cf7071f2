"""``fn(*args)`` in a fresh interpreter (multiprocessing's ``"spawn"``): the memory probes, the PPO
child and the soak's process per env run there.

A spawned child imports the same ``footstep_gym`` as this process (it gets this process's
import path) and none of its state. Its return value comes back through a pipe (it must
pickle). ``quiet=True`` sends the child's stdout and stderr to ``/dev/null`` (library warnings,
progress of code that is not ours); its error, if any, comes back as a
:class:`ChildFailed` either way.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import traceback
from typing import Any, Callable


class ChildFailed(RuntimeError):
    """The child raised (``status`` 1, ``message``: the exception's type and text), died without an answer
    (``status``: its exit code) or ran out of time (``status`` None)."""

    def __init__(self, message: str, status: int | None) -> None:
        super().__init__(message)
        self.status = status


def _child(conn: Any, fn: Callable[..., Any], args: tuple, quiet: bool) -> None:
    if quiet:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
    try:
        out = fn(*args)
    except BaseException as exc:  # noqa: BLE001 - reported to the parent, which decides
        traceback.print_exc()
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
        conn.close()
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(1)
    conn.send(("ok", out))
    conn.close()


def call_fresh(fn: Callable[..., Any], *args: Any, timeout: float | None = None, quiet: bool = False) -> Any:
    """``fn(*args)`` (a module-level function) in a fresh interpreter; its return value, or :class:`ChildFailed`."""
    ctx = multiprocessing.get_context("spawn")
    receive, send = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(send, fn, args, quiet))
    proc.start()
    send.close()
    try:
        if not receive.poll(timeout):  # None: wait as long as it takes; a child that died wakes it (EOF)
            proc.kill()
            raise ChildFailed(f"timed out after {timeout:g} s", None)
        try:
            kind, value = receive.recv()
        except EOFError:
            proc.join()
            raise ChildFailed(f"exited with status {proc.exitcode}", proc.exitcode) from None
        if kind == "error":
            raise ChildFailed(value, 1)
        return value
    finally:
        receive.close()
        proc.join()
