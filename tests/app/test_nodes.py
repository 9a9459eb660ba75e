"""Cheap writes of the loop thread (app/nodes.py): a plot's data as viser's own setter sends it."""

from __future__ import annotations

import numpy as np

from rigidlab.app.nodes import set_plot_data
from tests.app._wire import Recorder
from tests.helpers import wait_until


def _data_updates(recorder: Recorder, uuid: str) -> list[list[np.ndarray]]:
    return [message["updates"]["data"] for message, _ in recorder.received()
            if message.get("type") == "GuiUpdateMessage" and message.get("uuid") == uuid
            and "data" in message.get("updates", {})]


def test_set_plot_data_sends_what_visers_own_setter_sends(server) -> None:
    empty = np.zeros(2)
    ours = server.gui.add_uplot((empty, empty, empty), ({"label": "t"}, {"label": "a"}, {"label": "b"}))
    theirs = server.gui.add_uplot((empty, empty, empty), ({"label": "t"}, {"label": "a"}, {"label": "b"}))
    recorder = Recorder(f"ws://127.0.0.1:{server.get_port()}")
    try:
        t = np.linspace(0.0, 1.0, 7)
        columns = np.arange(21.0).reshape(7, 3)  # series as column views of one array, as a plot window holds them
        set_plot_data(ours, (t, columns[:, 0], columns[:, 2].astype(np.float32)))
        theirs.data = (t, columns[:, 0], columns[:, 2].astype(np.float32))
        columns[:] = -1.0  # the caller reuses its buffer: what was sent and stored is a copy
        for handle in (ours, theirs):
            stored = handle.data
            assert isinstance(stored, tuple) and all(a.dtype == np.float64 and a.flags.c_contiguous for a in stored)
            np.testing.assert_array_equal(stored[0], t)
            np.testing.assert_array_equal(stored[1], np.arange(0.0, 21.0, 3.0))
            np.testing.assert_array_equal(stored[2], np.arange(2.0, 21.0, 3.0))
        wait_until(lambda: _data_updates(recorder, ours._impl.uuid) and _data_updates(recorder, theirs._impl.uuid))
        (sent_ours,) = _data_updates(recorder, ours._impl.uuid)
        (sent_theirs,) = _data_updates(recorder, theirs._impl.uuid)
        assert len(sent_ours) == len(sent_theirs) == 3
        for a, b in zip(sent_ours, sent_theirs, strict=True):
            assert a.dtype == b.dtype == np.float64
            np.testing.assert_array_equal(a, b)
    finally:
        recorder.close()
    ours.remove()
    set_plot_data(ours, (t, t))  # a removed plot: nothing is sent, nothing raised
