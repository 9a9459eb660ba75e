"""Arm meshes: writes the small STL and OBJ meshes that examples/arm.urdf draws (run once; needs trimesh).

``python examples/arm_meshes.py`` writes ``examples/meshes/``: the base
(a pedestal, STL), the turret (a column with the shoulder's boss, STL), the
upper arm and the forearm (rounded bars, OBJ). Each mesh is in its link's
frame (metres, z up at the zero pose), low-poly so that each file stays
well under 50 kB.
"""

from pathlib import Path

import numpy as np
import trimesh


def _bar(length: float, width: float) -> trimesh.Trimesh:
    """A bar from the link origin down to z = -length, with rounded ends (capsule-like)."""
    body = trimesh.creation.box(extents=(width, 0.7 * width, length)).apply_translation((0, 0, -length / 2))
    ends = [trimesh.creation.cylinder(radius=width / 2, height=0.7 * width * 1.2, sections=16)
            .apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, (1, 0, 0)))
            .apply_translation((0, 0, z)) for z in (0.0, -length)]
    return trimesh.util.concatenate([body, *ends])


def main() -> None:
    out = Path(__file__).with_name("meshes")
    out.mkdir(exist_ok=True)
    base = trimesh.util.concatenate([
        trimesh.creation.cylinder(radius=0.16, height=0.04, sections=24).apply_translation((0, 0, 0.02)),
        trimesh.creation.cylinder(radius=0.08, height=0.08, sections=24).apply_translation((0, 0, 0.08)),
    ])
    turret = trimesh.util.concatenate([  # a column 1 m tall with the shoulder's boss at its top, towards +y
        trimesh.creation.cylinder(radius=0.05, height=1.0, sections=20).apply_translation((0, 0, 0.5)),
        trimesh.creation.cylinder(radius=0.045, height=0.08, sections=20)
        .apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, (1, 0, 0)))
        .apply_translation((0, 0.06, 1.0)),
    ])
    base.export(out / "base.stl")
    turret.export(out / "turret.stl")
    _bar(0.5, 0.08).export(out / "upper_arm.obj")
    _bar(0.4, 0.06).export(out / "forearm.obj")
    for path in sorted(out.iterdir()):
        print(f"{path.name}: {path.stat().st_size} bytes")


if __name__ == "__main__":
    main()
