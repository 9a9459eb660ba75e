"""Model files named on the command line (app.model_file): a good file builds, every bad one is one clear line."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from rigidlab.app.model_file import ModelFileError, load_model_file
from rigidlab.core.multibody import System

PENDULUM = '''
import numpy as np
from rigidlab.core.multibody import System

PARAMETERS = {
    "length": (1.0, 0.2, 3.0, "m", "Length"),
    "mass": (2.0, 0.1, 10.0, "kg", "Mass"),
}
SWEEP = "length"


def build(length, mass):
    system = System()
    bob = system.add_body("bob", mass=mass, inertia=(1e-4, 1e-4, 1e-4), position=(0.0, 0.0, -length))
    system.add_joint("revolute", system.ground, bob, point=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0))
    return system
'''


def _file(tmp_path, text: str, name: str = "model.py"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_a_python_model_file_builds_with_its_parameters(tmp_path):
    model = load_model_file(_file(tmp_path, PENDULUM))
    assert model.kind == "python" and model.name == "model.py" and model.sweep == "length"
    assert [p.name for p in model.parameters] == ["length", "mass"]
    assert model.parameters[0].title == "Length (m)"
    assert model.defaults() == {"length": 1.0, "mass": 2.0}
    system = model.build(length=2.0)
    assert isinstance(system, System)
    assert system.bodies[0].mass == 2.0  # the default
    np.testing.assert_array_equal(system.state.q[:3], (0.0, 0.0, -2.0))  # the bob's centre (q = R then p)
    assert len(model.sha256) == 64


@pytest.mark.parametrize(
    ("values", "message"),
    [({"width": 1.0}, r"width: expected one of the model's parameters \['length', 'mass'\]"),
     ({"length": 5.0}, r"length: expected a number in \[0.2, 3\], got 5.0"),
     ({"mass": float("nan")}, r"mass: expected a number in \[0.1, 10\], got nan")],
)
def test_build_refuses_unknown_names_and_values_out_of_range(tmp_path, values, message):
    model = load_model_file(_file(tmp_path, PENDULUM))
    with pytest.raises(ValueError, match=message):
        model.build(**values)


BAD = [
    ("syntax", "def build(:\n    pass\n", r"model.py:1: syntax error"),
    ("raises at import", "x = 1\nraise RuntimeError('no')\n", r"model.py:2: running the file raised RuntimeError: no"),
    ("no build", "x = 1\n", r"expected a function build\(\*\*parameters\) -> System, found none"),
    ("build raises", "def build():\n    return 1 / 0\n", r"model.py:2: build\(\) raised ZeroDivisionError"),
    ("not a System", "def build():\n    return 42\n", r"build\(\) expected to return a rigidlab.core.multibody.System, got int"),
    ("parameters not a dict", "PARAMETERS = [1]\ndef build():\n    pass\n", r"PARAMETERS: expected a dict"),
    ("short spec", "PARAMETERS = {'a': (1, 2)}\ndef build(a):\n    pass\n",
     r"PARAMETERS\['a'\]: expected \(default, low, high, unit, label\)"),
    ("default outside", "PARAMETERS = {'a': (5, 0, 1)}\ndef build(a):\n    pass\n",
     r"PARAMETERS\['a'\]: expected low < high and the default between them, got default 5"),
    ("not finite", "PARAMETERS = {'a': (1, 0, float('inf'))}\ndef build(a):\n    pass\n",
     r"PARAMETERS\['a'\]: expected finite numbers"),
    ("bad name", "PARAMETERS = {'a b': (1, 0, 2)}\ndef build(**k):\n    pass\n", r"expected names that are Python"),
    ("unknown sweep", "PARAMETERS = {'a': (1, 0, 2)}\nSWEEP = 'b'\ndef build(a):\n    pass\n",
     r"SWEEP: expected one of the PARAMETERS \['a'\], got 'b'"),
]


@pytest.mark.parametrize(("case", "text", "message"), BAD, ids=[b[0] for b in BAD])
def test_a_bad_python_model_file_is_one_clear_message_naming_it(tmp_path, case, text, message):
    path = _file(tmp_path, text)
    with pytest.raises(ModelFileError, match=message) as info:
        load_model_file(path)
    assert str(path) in str(info.value)
    assert "\n" not in str(info.value)


def test_missing_files_directories_and_unknown_suffixes_are_refused(tmp_path):
    with pytest.raises(ModelFileError, match=r"nope.py: no such file"):
        load_model_file(tmp_path / "nope.py")
    (tmp_path / "dir.py").mkdir()
    with pytest.raises(ModelFileError, match=r"dir.py: not a regular file"):
        load_model_file(tmp_path / "dir.py")
    with pytest.raises(ModelFileError, match=r"expected a model file ending in .py, .urdf, .xml, .mjcf, got '.txt'"):
        load_model_file(_file(tmp_path, "x", "model.txt"))


def test_a_bad_urdf_is_refused_with_the_loaders_message_once(tmp_path):
    pytest.importorskip("yourdfpy")
    path = _file(tmp_path, "<robot name='r'><link name='a'/><joint name='j' type='planar'>"
                           "<parent link='a'/><child link='a'/></joint></robot>", "bad.urdf")
    with pytest.raises(ModelFileError) as info:
        load_model_file(path)
    message = str(info.value)
    assert message.count(str(path)) == 1 and "\n" not in message, message
