"""MuJoCo's contact model, chosen once for every scene: the options of the step, the pads' contacts with the box
and the box's with the tables (`contact_options`, `pad_contact_params`, `set_pad_contacts`, `box_table_pairs`):
- Elliptic friction cones with impratio 10: the elliptic cone is Coulomb's law itself (a pyramid lets a pad slip
  sooner in some directions than others), and a ratio of frictional to normal impedance above 1 is what MuJoCo
  advises against slip of a grasped object (a box held by friction alone would creep out of the pads otherwise).
- The pads (robot geoms below the wrist sensors, which the robot's builder makes) get geom priority 2 (the box 1,
  everything else 0): the higher priority's friction, condim, solref and solimp make a contact. So pad-box contacts
  have condim 4 (torsional friction: the box does not pivot between the pads) with the box's sliding and spinning
  friction, what PyBullet uses (the product of the box's and the robot's friction, ROBOT_FRICTION = 1); the box
  against another robot link uses the box's friction and condim 3; against a table, explicit pairs with the
  product of the box's and the table's friction, as PyBullet (PyBullet's tables have no spinning friction).
- Rigid contacts keep MuJoCo's default solref (0.02 s, damping ratio 1: at least twice a 4 ms step) and solimp.
- Compliant pads (sim.pad_stiffness K [N/m], pad_damping D [N s/m]): MuJoCo's direct solref (-k, -b) sets a
  contact's reference acceleration -k r - b v per unit of its effective mass m, and its impedance d (solimp with
  dmin = dmax = d) lets the contact cancel only the fraction d of the other forces on it: a contact of impedance
  d on a body of mass m moves as a mass m / (1 - d) on a spring m k / (1 - d) with a damper m b / (1 - d). So
  k = K (1 - d) / m gives the pad's static stiffness (a resting load sinks by its weight over K), and
  b = D sqrt(1 - d) / m its damping ratio D / (2 sqrt(K m)); its ringing is slower by sqrt(1 - d) than the
  pad's, the price of an impedance high enough for a rigid grip in friction. Damping mapped as the stiffness is,
  (1 - d) / m, would leave the pad sqrt(1 - d) of its damping ratio: a squeeze of a heavy box bounces and the
  pads lose it. The pads press the box: m is the box's mass. Each contact point is such a spring, as
  with PyBullet's contactStiffness: a pad's face on the box's face makes 4.
  The spring is the pad's along its normal only: a geom's solref sets the friction directions too, and a pad
  as soft in shear lets a lifted box slide centimetres down the pads and pivot between them (PyBullet's
  contactStiffness leaves friction rigid). So a compliant pad's contacts with the box are explicit pairs with
  the pad's solref along the normal and MuJoCo's default in the friction directions (solreffriction)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from harmony_cli.maths.shapes import table_legs

if TYPE_CHECKING:
    from collections.abc import Iterable

    from harmony_cli.scenario.models import SimSpec
    from harmony_cli.scenario.world import BoxSpec, TableSpec

IMPRATIO = 10.0  # frictional over normal impedance: a held box does not creep out of the pads
PAD_IMPEDANCE = 0.9  # constant impedance d of compliant pads (solimp dmin = dmax)
RIGID_FRICTION = [0.02, 1.0]  # MuJoCo's default solref: the pads' friction on the box is not the pads' spring
PAD_PRIORITY, BOX_PRIORITY = 2, 1
TORSIONAL_CONDIM = 4  # normal, two tangents and spinning about the normal
ROLLING = 1e-4  # rolling friction (unused with condim <= 4; MuJoCo's default)
BOX_MASS = 0.8  # [kg] BoxSpec's default: the pads' effective mass without a box


def contact_options(spec: mujoco.MjSpec, sim_spec: SimSpec) -> None:
    """The step and the friction model every scene shares (see the module's docstring)."""
    spec.option.timestep = sim_spec.physics_dt
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = IMPRATIO


def pad_contact_params(sim_spec: SimSpec, box: BoxSpec | None = None) -> dict:
    """MjsGeom attributes of a pad: priority, condim, friction (the box's sliding and spinning friction), and with
    sim.pad_stiffness set, solref and solimp making the pad a spring of that stiffness and damping against the box."""
    sliding, spinning = (1.0, 0.1) if box is None else (box.friction, box.spinning_friction)
    params: dict = {
        "priority": PAD_PRIORITY,
        "condim": TORSIONAL_CONDIM,
        "friction": [sliding, spinning, ROLLING],
    }
    if sim_spec.pad_stiffness is not None:
        mass = BOX_MASS if box is None else box.mass
        stiffness = sim_spec.pad_stiffness * (1.0 - PAD_IMPEDANCE) / mass
        damping = sim_spec.pad_damping * np.sqrt(1.0 - PAD_IMPEDANCE) / mass
        params["solref"] = [-stiffness, -damping]
        params["solimp"] = [PAD_IMPEDANCE, PAD_IMPEDANCE, 0.001, 0.5, 2.0]
    return params


def set_pad_contacts(
    spec: mujoco.MjSpec, pads: Iterable[mujoco.MjsBody], sim_spec: SimSpec, box: BoxSpec | None = None
) -> None:
    """Give the geoms of the pads' bodies (of the robot's MjSpec, after add_world, before compiling)
    `pad_contact_params`; with compliant pads and a box, their contacts with the box as explicit pairs whose
    friction is rigid (RIGID_FRICTION), the automatic ones excluded (module docstring)."""
    params = pad_contact_params(sim_spec, box)
    paired = box is not None and sim_spec.pad_stiffness is not None
    sliding, spinning = params["friction"][:2]
    for body in pads:
        for i, geom in enumerate(body.geoms):
            for key, value in params.items():
                setattr(geom, key, value)
            if paired:
                geom.name = geom.name or f"{body.name}:pad{i}"
                pair = spec.add_pair(geomname1=geom.name, geomname2="box", condim=TORSIONAL_CONDIM)
                pair.friction = [sliding, sliding, spinning, ROLLING, ROLLING]
                pair.solref, pair.solimp, pair.solreffriction = params["solref"], params["solimp"], RIGID_FRICTION
        if paired:
            spec.add_exclude(bodyname1=body.name, bodyname2="box")


def box_table_pairs(spec: mujoco.MjSpec, b: BoxSpec, t: TableSpec) -> None:
    """The box's contacts with a table's top and legs as explicit pairs with the product of the two frictions, as
    PyBullet combines them (MuJoCo would take the box's alone); the automatic contacts between them excluded."""
    spec.add_exclude(bodyname1="box", bodyname2=f"table:{t.name}")
    sliding = b.friction * t.friction
    for part in ["top", *(f"leg{i}" for i in range(len(table_legs(t))))]:
        spec.add_pair(
            geomname1="box",
            geomname2=f"table:{t.name}:{part}",
            condim=3,
            friction=[sliding, sliding, 0.0, ROLLING, ROLLING],
        )
