"""Spring-mass chain: N equal blocks on a straight guide, joined by equal springs, the first to a wall.

Serve it with ``rigidlab serve --model examples/spring_chain.py``. Each block
slides along global x on a prismatic joint; spring 1 joins the wall at x = 0
to block 1, spring k blocks k - 1 and k; the last block is free. The System
is built with every block at rest and the last one pulled out by
``stretch`` (the simulation releases it). The equal chain fixed at one end
has the closed-form natural frequencies

    omega_r = 2 sqrt(k / m) sin((2 r - 1) pi / (2 (2 N + 1))),  r = 1 ... N,

which the mode-shapes panel reproduces (docs/guide/own_model.md).
"""

from rigidlab.core.multibody import System

N = 5
SPACING = 0.4  # m, the springs' free length
SIDE = 0.12  # m, the blocks' edge

PARAMETERS = {
    "stiffness": (400.0, 50.0, 2000.0, "N/m", "Spring stiffness k"),
    "mass": (1.0, 0.2, 5.0, "kg", "Block mass m"),
    "stretch": (0.15, 0.0, 0.3, "m", "Last block pulled out by"),
}


def build(stiffness=400.0, mass=1.0, stretch=0.15):
    """The chain at rest, the last block displaced by ``stretch`` (m), the others at their free positions."""
    system = System(gravity=(0.0, 0.0, -9.81))
    previous, x_previous = system.ground, 0.0
    for k in range(1, N + 1):
        x = k * SPACING + (stretch * k / N)  # the chain stretched evenly: every spring pulls
        block = system.add_box(f"block{k}", (x, 0.0, 0.5), (SIDE, SIDE, SIDE), mass)
        system.add_joint("prismatic", system.ground, block, point=(x, 0.0, 0.5), axis=(1.0, 0.0, 0.0),
                         name=f"guide{k}")
        system.add_spring_damper(previous, (x_previous, 0.0, 0.5), block, (x, 0.0, 0.5), stiffness=stiffness,
                                 damping=0.0, free_length=SPACING, name=f"spring{k}")
        previous, x_previous = block, x
    return system
