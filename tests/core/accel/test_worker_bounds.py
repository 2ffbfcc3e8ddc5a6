"""Bounds on the worker count (cores, rooms, memory) and a Dask scheduler that refuses the
connection reported at once."""
import socket
import warnings

import pytest

from invrad_wb.core.accel import workers as W
from invrad_wb.core.model import memory
from invrad_wb.errors import SettingsError


def test_workers_are_bounded_by_rooms_cores_and_memory(monkeypatch):
    monkeypatch.setattr(W, "usable_cores", lambda: 4)
    monkeypatch.setattr(memory, "budget", lambda: (64 << 30, "test"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert W.bound_workers(3, 64) == 3
        assert W.bound_workers(1000, 2) == 2          # one per room: nothing to say
    with pytest.warns(UserWarning, match="1000 workers asked for, 4 started: 4 usable"):
        assert W.bound_workers(1000, 64) == 4
    monkeypatch.setattr(memory, "budget", lambda: (3 * W.WORKER_BASE_BYTES,
                                                   "90% of ... (ulimit -v)"))
    with pytest.warns(UserWarning, match=r"4 workers asked for, 3 started: a memory budget"
                                         r".*ulimit -v"):
        assert W.bound_workers(4, 64) == 3


def test_a_refused_dask_connection_fails_at_once(monkeypatch):
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()                                           # nobody listens there now
    monkeypatch.setenv(W.ENV_DASK_TIMEOUT, "30")
    # the refusal itself is the answer (distributed's Client retried it for its timeout)
    with pytest.raises(SettingsError, match=r"cannot reach the Dask scheduler.*refused"):
        W.probe_scheduler(f"tcp://127.0.0.1:{port}", W.dask_timeout())
    with pytest.raises(SettingsError, match="not a scheduler address"):
        W.probe_scheduler("tcp://127.0.0.1:notaport", 1.0)


def test_the_dask_timeout_is_a_setting(monkeypatch):
    monkeypatch.delenv(W.ENV_DASK_TIMEOUT, raising=False)
    assert W.dask_timeout() == W.DASK_TIMEOUT_S
    monkeypatch.setenv(W.ENV_DASK_TIMEOUT, "2.5")
    assert W.dask_timeout() == 2.5
    for bad in ("soon", "-1", "0", "nan"):
        monkeypatch.setenv(W.ENV_DASK_TIMEOUT, bad)
        with pytest.raises(SettingsError, match=W.ENV_DASK_TIMEOUT):
            W.dask_timeout()
