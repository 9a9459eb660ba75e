"""Loading a state whose values each pass their control but not together (``Scene.values_refusal``).

A state is checked value by value by the controls; the scenes that build a
model from several values refuse some combinations only then (a rotor with
``I3 > 2 I``, a roller that undercuts its cam, a heavy top too slow for a
steady precession). Before, the load applied such a state, said "State
loaded", and the scene then set its controls back with a notice of its
own: two notices that contradicted each other. Now the load refuses the
state as a whole before anything is applied, with one notice.
"""

from __future__ import annotations

import json
import threading

import pytest

from tests.helpers import click, send_value, wait_for_frames, wait_until

# (scene, values each of which its control accepts, the scene's reason for refusing them together)
CASES = [
    ("gyroscope", {"I": 0.1, "I3": 5.0}, "invalid rotor parameters"),
    ("cam_follower", {"profile": "Rise-dwell-return, cycloidal", "follower": "Roller", "rise_deg": 30.0,
                      "roller_mm": 40.0}, "cam refused: Roller radius: a 40 mm roller would undercut this cam"),
    ("modes", {"model": "Heavy top", "top_motion": "slow precession", "top_spin": 0.5},
     "invalid parameters: spin: no steady precession exists"),
]


@pytest.mark.parametrize(("name", "values", "reason"), CASES, ids=[c[0] for c in CASES])
def test_values_refused_together_leave_the_scene_as_it_was(running_app, name, values, reason):
    scene = running_app(scene=name).scene_for()
    before = scene.controls.values()
    for key, value in values.items():  # each alone passes its control
        assert scene.controls.check({key: value}) == ({key: value}, []), key
    with pytest.raises(ValueError, match="^state: " + reason):
        scene.load_state({"scene": name, "values": values})
    assert scene.controls.values() == before
    assert not scene.controls.take_changes() - set(before)  # nothing was applied


def test_a_state_refused_together_gets_one_notice_through_the_share_panel(running_app):
    app = running_app(scene="gyroscope")
    session, scene = app.session_for(), app.scene_for()
    wait_until(lambda: scene.model is not None)
    before = scene.controls.values()
    count = len(session.notices)
    state = json.dumps({"scene": "gyroscope", "values": {"I": 0.1, "I3": 5.0}})
    assert send_value(session, "state_in", state)
    click(session, "load_state")
    assert wait_until(lambda: len(session.notices) > count)
    title, text = session.notices[-1][:2]
    assert title == "State not loaded"
    assert text.startswith("Gyroscope (cardan rotor): the values from the pasted state are refused together: invalid rotor "
                           "parameters: ") and text.endswith("The values in use are kept.")
    # the scene saw no change: no second notice setting the sliders back
    wait_for_frames(scene, 60)
    assert len(session.notices) == count + 1, session.notices[count:]
    assert scene.controls.values() == before
    # a state the scene accepts together still loads
    assert send_value(session, "state_in", json.dumps({"scene": "gyroscope", "values": {"I": 2.0, "I3": 3.0}}))
    click(session, "load_state")
    assert wait_until(lambda: session.notices[-1][0] == "State loaded")
    assert wait_until(lambda: scene.config.I == 2.0 and scene.config.I3 == 3.0)


def test_the_check_runs_off_the_loop(running_app, monkeypatch):
    """Building a model to check values together takes up to ~75 ms (a 20-link chain): not on the loop."""
    app = running_app(scene="gyroscope")
    session, scene = app.session_for(), app.scene_for()
    threads = []
    check = scene.values_refusal

    def recording(values):
        threads.append(threading.current_thread().name)
        return check(values)

    monkeypatch.setattr(scene, "values_refusal", recording)
    assert send_value(session, "state_in", json.dumps({"scene": "gyroscope", "values": {"I": 2.0, "I3": 3.0}}))
    click(session, "load_state")
    assert wait_until(lambda: session.notices and session.notices[-1][0] == "State loaded")
    assert threads and all(name.startswith("rigidlab-load") for name in threads), threads
