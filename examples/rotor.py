"""Rotor on a flexible shaft: a disk spinning on a massless elastic shaft between two bearings (Jeffcott).

Serve it with ``rigidlab serve --model examples/rotor.py``. The disk (a
uniform cylinder) spins at ``spin`` about the shaft's axis (global x); the
shaft's bending is two springs from the bearings at x = -span/2 and
x = +span/2 to the disk's hub, with a little damping. The mode-shapes panel
shows the forward and backward whirl split by the gyroscopic coupling, and
``SWEEP = "spin"`` draws the Campbell diagram over the spin speed in the
background.
"""

from rigidlab.core.multibody import System

PARAMETERS = {
    "spin": (200.0, 0.0, 1000.0, "rad/s", "Spin speed Ω"),
    "stiffness": (2.0e4, 5.0e3, 5.0e4, "N/m", "Shaft stiffness per bearing"),
    "damping": (2.0, 0.0, 20.0, "N s/m", "Bearing damping"),
}
SWEEP = "spin"

MASS, RADIUS, THICKNESS, SPAN = 2.0, 0.15, 0.03, 0.6  # kg, m, m, m


def build(spin=200.0, stiffness=2.0e4, damping=2.0):
    """The rotor in its steady spin (the shaft bent by the disk's weight), at ``spin`` rad/s about +x."""
    system = System(gravity=(0.0, 0.0, -9.81))
    sag = MASS * 9.81 / (2.0 * stiffness)
    polar = 0.5 * MASS * RADIUS**2
    transverse = MASS * (3.0 * RADIUS**2 + THICKNESS**2) / 12.0
    disk = system.add_body("disk", mass=MASS, inertia=(polar, transverse, transverse), position=(0.0, 0.0, 1.0 - sag),
                           omega_body=(spin, 0.0, 0.0))
    for x, name in ((-0.5 * SPAN, "bearing_left"), (0.5 * SPAN, "bearing_right")):
        system.add_spring_damper(system.ground, (x, 0.0, 1.0), disk, (x, 0.0, 1.0 - sag), stiffness=stiffness,
                                 damping=damping, free_length=0.0, name=name)
    system.assemble()
    return system
