"""Writes fbcc_ros/urdf/iiwa7.urdf, med7.urdf and med14.urdf from the public data vendored
below, in the conventions of our hand-written iiwa14.urdf (joint names iiwa_joint_1..7 for every
LBR, link frames oriented as there, the flange frame iiwa_flange and a peg link 0.10 m out).

    .venv/bin/python scripts/make_lbr_urdf.py          # (re)write the three files
    .venv/bin/python scripts/make_lbr_urdf.py --check  # exit 1 if a file is not its rendering

Sources (each URDF's header repeats what it uses):

- STACK: lbr_fri_ros2_stack (github.com/lbr-stack/lbr_fri_ros2_stack, Apache-2.0) at commit
  218d723f817c61314988833611effddc5333ca6c, lbr_description/: urdf/<model>/joint_limits.yaml
  (axis ranges and speeds; its lbr_description/test/lbr_model_specifications.py gives the same
  figures and the masses "as extracted from https://xpert.kuka.com/"), and
  urdf/<model>/<model>_description.xacro (joint origins; link masses, centres of mass and
  inertias from a CAD export, fusion2urdf, scaled to the published mass by the stack's
  scripts/normalize_mass.py).
- KUKA's data sheets for the axis offsets, and for the LBR iiwa 7 R800's maximum torques KUKA's
  "LBR iiwa technical data" axis table as recorded in Drake's
  manipulation/models/iiwa_description/README.md.

The stack's link frames are all parallel to the base at the zero pose, and its links 2, 4 and 6
have their origins off the centre line along their own joint axes (10 mm, 10.5 mm, 70.7 mm).
Ours lie on the centre line and are turned as in iiwa14.urdf. Both are fixed to the same body, so
each centre of mass and inertia is carried over exactly: c' = R^T (c + d), I' = R^T I R, with R a
rotation by multiples of 90 degrees and d the origin's offset along its axis.
"""

from __future__ import annotations

import argparse
import math
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np

URDF_DIR = Path(__file__).resolve().parents[1] / "fbcc_ros" / "urdf"

# Our link frames (iiwa14.urdf): each joint's origin rpy, and the axis of its parent frame along
# which the joint origin is offset (the axis that points along the arm at the zero pose).
OUR_RPY = (
    (0.0, 0.0, 0.0),
    (math.pi / 2, 0.0, math.pi),
    (math.pi / 2, 0.0, math.pi),
    (math.pi / 2, 0.0, 0.0),
    (-math.pi / 2, math.pi, 0.0),
    (math.pi / 2, 0.0, 0.0),
    (-math.pi / 2, math.pi, 0.0),
)
OUR_OFFSET_AXIS = (2, 2, 1, 2, 1, 2, 1, 2)  # joints 1..7, then the flange: z, z, y, z, y, z, y, z
# The joint axes at the zero pose in the base frame (KUKA's positive directions).
AXES = ((0, 0, 1), (0, 1, 0), (0, 0, 1), (0, -1, 0), (0, 0, 1), (0, 1, 0), (0, 0, 1))

# STACK joint_limits.yaml, A1..A7: (range +- [deg], speed [deg/s]). The yaml's "effort: 200" on
# every axis of every model is a placeholder, not KUKA's figure, and is not used.
LIMITS_7 = ((170, 98), (120, 98), (170, 100), (120, 130), (170, 140), (120, 180), (175, 180))
LIMITS_14 = ((170, 85), (120, 85), (170, 100), (120, 75), (170, 130), (120, 135), (175, 135))
# Maximum torques [N m], A1..A7: the LBR iiwa 7 R800's (KUKA "LBR iiwa technical data", via
# Drake's iiwa_description/README.md) and the LBR iiwa 14 R820's (KUKA brochure, as iiwa14.urdf).
TORQUES_7 = (176, 176, 110, 110, 110, 40, 40)
TORQUES_14 = (320, 320, 176, 176, 110, 40, 40)

# One inertial: mass [kg], centre of mass xyz [m], inertia ixx ixy ixz iyy iyz izz [kg m^2].
Vector3 = tuple[float, float, float]
Inertial = tuple[float, Vector3, tuple[float, float, float, float, float, float]]


@dataclass(frozen=True)
class Model:
    name: str
    title: str
    kuka_id: str
    mass: float  # STACK lbr_model_specifications.py (xpert.kuka.com) [kg]
    offsets: tuple[float, float, float, float]  # base-A2, A2-A4, A4-A6, A6-flange [m]
    split: tuple[float, ...]  # our joint 1..7 and flange offsets along the arm [m]
    stack_joints: tuple[Vector3, ...]  # STACK A1..A7, joint_ee origin xyz
    inertials: tuple[Inertial, ...]  # STACK link_0..link_7
    limits: tuple[tuple[int, int], ...]
    torques: tuple[int, ...]
    kinematics: str  # the header's [1]: where the offsets come from
    torque_source: str  # the header's [3]


# STACK <model>_description.xacro, verbatim: the origin xyz of joints A1..A7 and joint_ee (every
# rpy there is 0 0 0) and each link's inertial (every inertial rpy is 0 0 0).
_JOINTS_7 = (
    (0.0, 0.0, 0.1475),
    (0.0, -0.0105, 0.1925),
    (0.0, 0.0105, 0.2075),
    (0.0, 0.0105, 0.1925),
    (0.0, -0.0105, 0.2075),
    (0.0, -0.0707, 0.1925),
    (0.0, 0.0707, 0.091),
    (0.0, 0.0, 0.035),
)
_JOINTS_MED14 = (
    (0.0, 0.0, 0.147),
    (0.0, -0.01, 0.2125),
    (0.0, 0.01, 0.228),
    (0.0, 0.0105, 0.192),
    (0.0, -0.0105, 0.2075),
    (0.0, -0.0707, 0.1925),
    (0.0, 0.0707, 0.091),
    (0.0, 0.0, 0.035),
)
_INERTIALS_IIWA7: tuple[Inertial, ...] = (
    (4.855658, (-0.012857, 0.0, 0.069964), (0.017839, 0.0, 0.000781, 0.022294, 0.0, 0.021334)),
    (3.394011, (0.0, -0.034819, 0.123299), (0.021383, 0.0, 0.0, 0.020403, 0.003797, 0.007563)),
    (4.031991, (0.0, 0.039793, 0.086944), (0.031697, 0.0, 0.0, 0.03008, 0.005889, 0.009666)),
    (3.394011, (0.0, 0.034819, 0.123299), (0.021383, 0.0, 0.0, 0.020403, -0.003797, 0.007563)),
    (4.031989, (0.0, -0.039793, 0.086944), (0.031695, 0.0, 0.0, 0.030079, -0.005889, 0.009665)),
    (1.529239, (0.0, -0.029824, 0.076267), (0.008485, 0.0, 0.0, 0.007136, 0.002806, 0.003848)),
    (2.403626, (0.0, 0.07102, 0.00495), (0.007067, 0.0, 0.0, 0.006804, 0.000311, 0.004629)),
    (0.259474, (3.0e-06, -2.0e-06, 0.013782), (0.000171, 0.0, 0.0, 0.000171, 0.0, 0.000299)),
)
_INERTIALS_MED7: tuple[Inertial, ...] = (
    (7.143112, (-0.001896, 0.0, 0.076263), (0.038694, 0.0, -0.000686, 0.039461, 0.0, 0.054387)),
    (3.271499, (0.0, -0.034819, 0.123299), (0.020611, 0.0, 0.0, 0.019667, 0.00366, 0.00729)),
    (3.886413, (0.0, 0.039793, 0.086944), (0.030552, 0.0, 0.0, 0.028995, 0.005676, 0.009317)),
    (3.271499, (0.0, 0.034819, 0.123299), (0.020611, 0.0, 0.0, 0.019667, -0.00366, 0.00729)),
    (3.886411, (0.0, -0.039793, 0.086944), (0.030547, 0.0, 0.0, 0.028993, -0.005676, 0.009313)),
    (1.474048, (0.0, -0.029824, 0.076267), (0.008179, 0.0, 0.0, 0.006879, 0.002704, 0.003709)),
    (2.316911, (-1.0e-06, 0.07102, 0.004953), (0.006813, 0.0, 0.0, 0.006559, 0.0003, 0.004462)),
    (0.250108, (3.0e-06, -2.0e-06, 0.013782), (0.000165, 0.0, 0.0, 0.000165, 0.0, 0.000288)),
)
_INERTIALS_MED14: tuple[Inertial, ...] = (
    (8.146413, (-0.001864, 0.0, 0.077517), (0.044604, 0.0, -0.000788, 0.045465, 0.0, 0.061904)),
    (5.591419, (0.0, -0.033795, 0.132404), (0.044885, 0.0, 0.0, 0.045283, 0.006703, 0.016776)),
    (
        6.013411,
        (0.000136, 0.047546, 0.076324),
        (0.05833, -3.5e-05, 5.9e-05, 0.057062, 0.010605, 0.017466),
    ),
    (3.65879, (0.0, 0.034913, 0.123108), (0.02296, 0.0, 0.0, 0.021913, -0.004065, 0.00814)),
    (4.358267, (0.0, -0.039793, 0.086944), (0.034255, 0.0, 0.0, 0.032512, -0.006365, 0.010444)),
    (1.653015, (0.0, -0.029824, 0.076267), (0.009172, 0.0, 0.0, 0.007714, 0.003033, 0.004159)),
    (2.598211, (-1.0e-06, 0.07102, 0.004953), (0.00764, 0.0, 0.0, 0.007355, 0.000336, 0.005004)),
    (0.280474, (3.0e-06, -2.0e-06, 0.013782), (0.000185, 0.0, 0.0, 0.000185, 0.0, 0.000323)),
)

_SPLIT_7 = (0.1475, 0.1925, 0.2075, 0.1925, 0.2075, 0.1925, 0.091, 0.035)

MODELS = (
    Model(
        name="iiwa7",
        title="KUKA LBR iiwa 7 R800",
        kuka_id="AR7606",
        mass=23.9,
        offsets=(0.340, 0.400, 0.400, 0.126),
        split=_SPLIT_7,
        stack_joints=_JOINTS_7,
        inertials=_INERTIALS_IIWA7,
        limits=LIMITS_7,
        torques=TORQUES_7,
        kinematics=(
            "KUKA, LBR iiwa 7 R800 specification: axis offsets 340 / 400 / 400 / 126 mm (base"
            " to A2, A2 to A4, A4 to A6, A6 to the flange; 1266 mm from the mounting face to the"
            " flange at the zero pose)."
        ),
        torque_source=(
            'Maximum torques 176, 176, 110, 110, 110, 40, 40 N m: KUKA, "LBR iiwa technical'
            " data\", axis table, as recorded in Drake's"
            ' manipulation/models/iiwa_description/README.md ("Velocity and Effort Limits for'
            ' IIWA 7"; its speeds agree with [2]).'
        ),
    ),
    Model(
        name="med7",
        title="KUKA LBR Med 7 R800",
        kuka_id="AR16388",
        mass=25.5,
        offsets=(0.340, 0.400, 0.400, 0.126),
        split=_SPLIT_7,
        stack_joints=_JOINTS_7,
        inertials=_INERTIALS_MED7,
        limits=LIMITS_7,
        torques=TORQUES_7,
        kinematics=(
            "The LBR Med 7 R800 is taken to have the kinematics of the LBR iiwa 7 R800 (KUKA"
            " specification of the iiwa 7): axis offsets 340 / 400 / 400 / 126 mm (base to"
            " A2, A2 to A4, A4 to A6, A6 to the flange; 1266 mm from the mounting face to the"
            " flange at the zero pose). The"
            " stack's med7_description.xacro has the same joint origins as its iiwa7 one."
        ),
        torque_source=(
            "Maximum torques: we found no published figure for the Med and use the LBR iiwa 7"
            ' R800\'s, 176, 176, 110, 110, 110, 40, 40 N m (KUKA, "LBR iiwa technical data", as'
            " recorded in Drake's manipulation/models/iiwa_description/README.md). An"
            " assumption, not a datum."
        ),
    ),
    Model(
        name="med14",
        title="KUKA LBR Med 14 R820",
        kuka_id="AR16387",
        mass=32.3,
        offsets=(0.360, 0.420, 0.400, 0.126),
        split=(0.1475, 0.2125, 0.228, 0.192, 0.2075, 0.1925, 0.091, 0.035),
        stack_joints=_JOINTS_MED14,
        inertials=_INERTIALS_MED14,
        limits=LIMITS_14,
        torques=TORQUES_14,
        kinematics=(
            "The LBR Med 14 R820 is taken to have the kinematics of the LBR iiwa 14 R820 (KUKA"
            " specification of the iiwa 14): axis offsets 360 / 420 / 400 / 126 mm (base to"
            " A2, A2 to A4, A4 to A6, A6 to the flange; 1306 mm from the mounting face to the"
            " flange at the zero pose). The stack's med14_description.xacro differs by 0.5"
            " mm: its A1 origin is at 0.147 m (0.1475 m in its iiwa14, iiwa7 and med7), so"
            " its A2 is 359.5 mm above the base and its flange 0.5 mm lower at every pose. We"
            " keep 360 mm (A1 at 0.1475 m, as its iiwa14) and each link's inertial relative to"
            " its own link frame."
        ),
        torque_source=(
            "Maximum torques: we found no published figure for the Med and use the LBR iiwa 14"
            " R820's, 320, 320, 176, 176, 110, 40, 40 N m (KUKA brochure, as in iiwa14.urdf)."
            " An assumption, not a datum."
        ),
    ),
)


def _rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = (f(a) for a in (roll, pitch, yaw) for f in (math.cos, math.sin))
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    product: np.ndarray = rz @ ry @ rx
    return product


def _our_link_rotations() -> list[np.ndarray]:
    """Our link 1..7 frames' orientations in the base frame at the zero pose: exact signed
    permutation matrices (checked against the joint axes)."""
    rot, out = np.eye(3), []
    for rpy, axis in zip(OUR_RPY, AXES, strict=True):
        rot = rot @ _rpy_matrix(*rpy)
        exact = np.round(rot)
        assert np.allclose(rot, exact, atol=1e-12)
        assert tuple(exact[:, 2].astype(int)) == axis, "joint axis z must be KUKA's direction"
        out.append(exact)
    return out


def _carried_over(model: Model) -> list[Inertial]:
    """The stack's inertials in our link frames: link 0 (the base) as it is; link i through the
    constant transform between the stack's link frame and ours (same body)."""
    rotations = _our_link_rotations()
    out = [model.inertials[0]]
    origin = np.zeros(3)
    for i, (mass, com, inertia) in enumerate(model.inertials[1:]):
        origin = origin + np.array(model.stack_joints[i])  # stack link i origin, zero pose
        offset = np.array([origin[0], origin[1], 0.0])  # from our origin on the centre line
        rot = rotations[i]
        ixx, ixy, ixz, iyy, iyz, izz = inertia
        tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        c = rot.T @ (np.array(com) + offset)
        t = rot.T @ tensor @ rot
        out.append(
            (
                mass,
                (float(c[0]), float(c[1]), float(c[2])),
                (t[0, 0], t[0, 1], t[0, 2], t[1, 1], t[1, 2], t[2, 2]),
            )
        )
    return out


def _num(x: float) -> str:
    """A decimal with at most 9 places and no trailing zeros (the inputs have at most 7)."""
    s = f"{x:.9f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _rad(x: float) -> str:
    return f"{x:.10f}"


def _inertial_xml(inertial: Inertial, indent: str) -> list[str]:
    mass, com, (ixx, ixy, ixz, iyy, iyz, izz) = inertial
    names = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    values = zip(names, (ixx, ixy, ixz, iyy, iyz, izz), strict=True)
    attributes = " ".join(f'{key}="{_num(value)}"' for key, value in values)
    return [
        f"{indent}<inertial>",
        f'{indent}  <origin xyz="{" ".join(_num(v) for v in com)}" rpy="0 0 0"/>',
        f'{indent}  <mass value="{_num(mass)}"/>',
        f"{indent}  <inertia {attributes}/>",
        f"{indent}</inertial>",
    ]


def _header(model: Model) -> list[str]:
    d = [round(1000 * x) for x in model.offsets]
    s = model.split
    split = ", ".join(
        f"{_num(a)} + {_num(b)} = {_num(a + b)}" for a, b in zip(s[0::2], s[1::2], strict=True)
    )
    ranges = ", ".join(str(r) for r, _ in model.limits)
    speeds = ", ".join(str(v) for _, v in model.limits)
    stack = f"lbr_fri_ros2_stack (Apache-2.0) at commit 218d723, lbr_description/urdf/{model.name}"
    stack += "/"
    cited = [
        f"[1] {model.kinematics}",
        f"[2] {stack}joint_limits.yaml: KUKA's figures for {model.kuka_id} from xpert.kuka.com"
        " (the stack's lbr_description/test/lbr_model_specifications.py gives the same, and the"
        f" mass {_num(model.mass)} kg): axis ranges +-{ranges} deg and maximum speeds {speeds}"
        ' deg/s (A1..A7). Its "effort: 200" on every axis is a placeholder, not used; see [3].',
        f"[3] {model.torque_source}",
        f"[4] {stack}{model.name}_description.xacro (a CAD export by fusion2urdf, masses scaled"
        f" to KUKA's {_num(model.mass)} kg): the split of each offset between link frames"
        f" ({split}) and the link masses, centres of mass and inertias. The stack's link frames"
        " are parallel to the base at the zero pose and the origins of its links 2, 4 and 6 lie"
        " off the centre line, along their own joint axes; ours lie on the centre line and are"
        " turned as in iiwa14.urdf (the iiwa_stack convention). Both frames are fixed to the"
        " same link, so each centre of mass and inertia is carried over exactly (c' = R^T (c +"
        " d), I' = R^T I R, R a rotation by multiples of 90 deg, d the origin's offset along"
        " the joint axis); nothing is re-estimated. The masses sum to"
        f" {_num(sum(i[0] for i in model.inertials))} kg.",
        "[5] Joint axis directions at the zero pose, in the base frame: A1, A3, A5, A7 along +z;"
        " A2 and A6 along +y; A4 along -y (KUKA's positive directions, as in iiwa14.urdf)."
        " test/core/kinematics/test_lbr_models.py checks the model against a product of"
        f" exponentials built from [1] and [5] ({d[0]}/{d[1]}/{d[2]}/{d[3]} mm), against the"
        " stack's joint chain, and its limits against [2].",
    ]
    lines = [
        f"{model.title}, for fbcc_ros: kinematics, limits and rigid-body parameters only (no",
        "meshes, no collision geometry). Generated by scripts/make_lbr_urdf.py from the public",
        "data below: edit the script and re-run it, not this file.",
        "",
    ]
    for paragraph in cited:
        lines += textwrap.wrap(paragraph, width=94, subsequent_indent="    ")
    lines += [
        "",
        "Frames added by fbcc_ros:",
        f"- iiwa_flange: the KUKA flange frame, {_num(1000 * s[7])} mm beyond joint 7's link frame"
        " along its axis,",
        "  z out of the flange; at the zero pose it is parallel to the base frame. It coincides",
        "  with the stack's link_ee.",
        "- peg: the tool (peg) frame: origin at the centre of the peg's end face, z along the peg",
        "  axis pointing out of the flange (the approach direction). The default places the tip",
        "  0.10 m from the flange; fbcc_ros.core.kinematics overrides this placement with the",
        "  configured tool.",
        "",
        "Joint names are the iiwa's (iiwa_joint_1..7) for every LBR model, so they share them.",
    ]
    return ["  " + line if line else "" for line in lines]


def render(model: Model) -> str:
    assert abs(sum(model.split) - sum(model.offsets)) < 1e-12
    s = model.split
    sums = (s[0] + s[1], s[2] + s[3], s[4] + s[5], s[6] + s[7])
    for got, want in zip(sums, model.offsets, strict=True):
        assert abs(got - want) < 1e-12, (model.name, got, want)
    inertials = _carried_over(model)
    out = ['<?xml version="1.0"?>', "<!--", *_header(model), "-->", f'<robot name="{model.name}">']
    out += ['  <link name="iiwa_link_0">', *_inertial_xml(inertials[0], "    "), "  </link>"]
    for i in range(7):
        xyz = ["0", "0", "0"]
        xyz[OUR_OFFSET_AXIS[i]] = _num(model.split[i])
        rpy = " ".join("0" if a == 0 else _rad(a) for a in OUR_RPY[i])
        limit, speed = model.limits[i]
        out += [
            "",
            f'  <joint name="iiwa_joint_{i + 1}" type="revolute">',
            f'    <parent link="iiwa_link_{i}"/>',
            f'    <child link="iiwa_link_{i + 1}"/>',
            f'    <origin xyz="{" ".join(xyz)}" rpy="{rpy}"/>',
            '    <axis xyz="0 0 1"/>',
            f'    <limit lower="{_rad(-math.radians(limit))}" upper="{_rad(math.radians(limit))}"'
            f' effort="{model.torques[i]}" velocity="{_rad(math.radians(speed))}"/>',
            "  </joint>",
            f'  <link name="iiwa_link_{i + 1}">',
            *_inertial_xml(inertials[i + 1], "    "),
            "  </link>",
        ]
    out += [
        "",
        '  <joint name="iiwa_flange_joint" type="fixed">',
        '    <parent link="iiwa_link_7"/>',
        '    <child link="iiwa_flange"/>',
        f'    <origin xyz="0 0 {_num(model.split[7])}" rpy="0 0 0"/>',
        "  </joint>",
        '  <link name="iiwa_flange"/>',
        "",
        '  <joint name="peg_joint" type="fixed">',
        '    <parent link="iiwa_flange"/>',
        '    <child link="peg"/>',
        '    <origin xyz="0 0 0.10" rpy="0 0 0"/>',
        "  </joint>",
        '  <link name="peg"/>',
        "</robot>",
    ]
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare, do not write")
    args = parser.parse_args(argv)
    stale = []
    for model in MODELS:
        path = URDF_DIR / f"{model.name}.urdf"
        text = render(model)
        if args.check:
            if not path.is_file() or path.read_text() != text:
                stale.append(path.name)
        else:
            path.write_text(text)
            print(f"wrote {path}")
    if stale:
        print(f"differ from their rendering: {', '.join(stale)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
