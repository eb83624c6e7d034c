"""Sweeps and envelopes on a Dask cluster: reaching the scheduler (fail fast, one line, when
nothing or something else answers) and running trials as tasks, a task a chunk of trial setups,
rows recorded as tasks finish, the trials of a task whose workers keep dying reported lost."""

from __future__ import annotations

import asyncio
import contextlib
import socket
import threading
from collections.abc import Callable, Iterator
from typing import Any
from urllib.parse import urlsplit

from biped.errors import ScenarioError

#: Seconds to wait for a Dask scheduler before giving up.
SCHEDULER_TIMEOUT_S = 5.0


def check_scheduler(address: str, timeout_s: float = SCHEDULER_TIMEOUT_S) -> None:
    """Fail fast (:class:`ScenarioError`) if nothing listens at a Dask scheduler's address."""
    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        host = port = None
    if parts.scheme not in ("tcp", "tls") or not host or not port:
        raise ScenarioError(
            f"--scheduler must be a Dask address such as tcp://10.0.0.5:8786; got {address!r}"
        )
    try:
        socket.create_connection((host, port), timeout=timeout_s).close()
    except OSError as exc:
        raise ScenarioError(
            f"cannot reach the Dask scheduler at {address!r} "
            f"({exc.strerror or exc}); is `dask scheduler` running there?"
        ) from None


async def _dask_identity(address: str, timeout_s: float) -> Any:
    """What the peer at ``address`` says to Dask's ``identity`` request."""
    from distributed.comm import connect

    comm = await connect(address, timeout=timeout_s)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await asyncio.wait_for(comm.read(), timeout_s)
    finally:
        comm.abort()


def _in_own_loop(coro: Any, timeout_s: float) -> Any:
    """Run ``coro`` to its end in a new event loop on a thread of its own (a caller inside a
    running loop, e.g. Jupyter, cannot ``asyncio.run``), with a hard limit of ``timeout_s``."""
    box: dict[str, Any] = {}

    def run() -> None:
        try:
            box["value"] = asyncio.run(asyncio.wait_for(coro, timeout_s))
        except BaseException as exc:  # noqa: BLE001 - handed to the caller
            box["error"] = exc

    thread = threading.Thread(target=run, name="biped-dask-probe", daemon=True)
    thread.start()
    thread.join(timeout_s + 1.0)
    if thread.is_alive():
        raise TimeoutError
    if "error" in box:
        raise box["error"]
    return box["value"]


def connect_scheduler(address: str, timeout_s: float | None = None) -> Any:
    """A ``dask.distributed.Client`` of the scheduler at ``address``, or a one-line
    :class:`ScenarioError` within ``2 * timeout_s`` seconds when nothing listens there or the
    peer is not a Dask scheduler (it says nothing, or something else). The client's own timeout
    is not honoured by a peer that accepts and stays silent, so the peer is first asked Dask's
    ``identity`` under a hard limit, and only a scheduler gets a client. ``timeout_s``: default
    :data:`SCHEDULER_TIMEOUT_S`."""
    timeout_s = SCHEDULER_TIMEOUT_S if timeout_s is None else timeout_s
    check_scheduler(address, timeout_s)
    try:
        reply = _in_own_loop(_dask_identity(address, timeout_s), 2 * timeout_s)
    except TimeoutError:
        raise ScenarioError(
            f"--scheduler {address!r}: something listens there but no Dask scheduler answered "
            f"within {2 * timeout_s:g} s; give the address of a running `dask scheduler`"
        ) from None
    except Exception as exc:  # noqa: BLE001 - a peer speaking garbage can raise anything
        first = (str(exc).strip().splitlines() or [""])[0][:200]
        raise ScenarioError(
            f"--scheduler {address!r} is not a Dask scheduler ({type(exc).__name__}"
            f"{': ' + first if first else ''}); give the address of a running `dask scheduler`"
        ) from None
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        what = reply.get("type") if isinstance(reply, dict) else type(reply).__name__
        raise ScenarioError(
            f"--scheduler {address!r} is not a Dask scheduler (it says it is {what!r}); give the "
            f"address of a running `dask scheduler`"
        )
    from dask.distributed import Client

    return Client(address, timeout=f"{timeout_s}s")


def _execute_many(trial_fn: Callable, setups: list) -> list[dict]:
    from biped.sim.sweep.runner import execute_trial

    return [execute_trial(trial_fn, s) for s in setups]


def _client_at(address: Any) -> Any:
    """A plain ``dask.distributed.Client`` of ``address`` (``biped envelope``'s way in)."""
    from dask.distributed import Client

    try:
        return Client(address, timeout=f"{SCHEDULER_TIMEOUT_S}s")
    except OSError as exc:
        raise ScenarioError(f"cannot connect to the Dask scheduler at {address!r}: {exc}") from None


@contextlib.contextmanager
def _client(scheduler: Any, connect: Callable[[Any], Any]) -> Iterator[Any]:
    """``scheduler`` itself when it is a Client; else ``connect(scheduler)``, closed after."""
    from dask.distributed import Client

    if isinstance(scheduler, Client):
        yield scheduler
        return
    client = connect(scheduler)
    try:
        yield client
    finally:
        client.close()


def run_tasks(
    scheduler: Any,
    trial_fn: Callable,
    next_chunk: Callable[[], list | None],
    record: Callable[[list[dict]], None],
    lost: Callable[[list], None],
    connect: Callable[[Any], Any] = _client_at,
) -> None:
    """A task for every chunk of setups ``next_chunk()`` gives (None: none now), asked again as
    each task finishes (the next may depend on its rows); ``record(rows)`` as tasks finish, and
    ``lost(chunk)`` for a task whose workers keep dying (dask's KilledWorker; trial errors are
    rows). Returns when no task runs and ``next_chunk()`` has nothing. ``scheduler``: a Client
    or an address, connected by ``connect`` (and closed after)."""
    from dask.distributed import as_completed

    with _client(scheduler, connect) as client:
        futures: dict = {}

        def submit_all(ac=None) -> None:
            while (chunk := next_chunk()) is not None:
                fut = client.submit(_execute_many, trial_fn, chunk, pure=False)
                futures[fut] = chunk
                if ac is not None:
                    ac.add(fut)

        submit_all()
        ac = as_completed(list(futures))
        try:
            for fut in ac:
                chunk = futures.pop(fut)
                try:
                    rows = fut.result()
                except Exception:  # noqa: BLE001 - the worker died (trial errors are rows)
                    lost(chunk)
                else:
                    record(rows)
                submit_all(ac)
        except BaseException:
            client.cancel(list(futures))
            raise


def run_chunks(scheduler: Any, trial_fn: Callable, spec: Any, chunks: list, record: Callable) -> int:
    """A sweep's chunks of trials (every one submitted at once), each a task; returns the number
    of trials lost. A string ``scheduler`` is reached by :func:`connect_scheduler`."""
    todo = iter(chunks)
    n_lost = [0]

    def next_chunk() -> list | None:
        c = next(todo, None)
        return None if c is None else [spec.setup(t) for t in c]

    def lost(setups: list) -> None:
        n_lost[0] += len(setups)

    run_tasks(scheduler, trial_fn, next_chunk, record, lost, connect=lambda a: connect_scheduler(str(a)))
    return n_lost[0]


def stream(scheduler: Any, trial_fn: Callable, next_setup, record, lost) -> None:
    """Adaptive work (``biped envelope``): one task a trial, the next submitted as each finishes
    (the next trial of that direction); a task whose workers keep dying goes to ``lost``."""

    def next_chunk() -> list | None:
        setup = next_setup()
        return None if setup is None else [setup]

    run_tasks(scheduler, trial_fn, next_chunk, record, lost)


__all__ = ["SCHEDULER_TIMEOUT_S", "check_scheduler", "connect_scheduler", "run_chunks", "run_tasks", "stream"]
