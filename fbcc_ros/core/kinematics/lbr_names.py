"""Our LBR models under lbr_fri_ros2_stack's names, for rehearsing beside that stack.

The stack's description (``lbr_description/urdf/<model>/<model>_description.xacro``) names the
joints ``<robot_name>_A1`` … ``_A7``, the links ``<robot_name>_link_0`` … ``_link_7`` and the
tool flange ``<robot_name>_link_ee``, under a root ``<robot_name>_floating_link``; its
``robot_name`` is ``lbr`` by default. Our URDFs name them ``iiwa_joint_i``, ``iiwa_link_i`` and
``iiwa_flange``. The joint axes, their zero and the flange are the same in both (checked against
the stack's numbers in ``test/core/kinematics/test_lbr_models.py``; the stack's Med 14 alone
sits 0.5 mm lower, ``docs/kinematics.md``), so renaming is all it takes for the joints, the
base and the flange; the intermediate links keep our frames, which differ from the stack's by a
fixed rotation per link (no frame but the base and the flange is used here).
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from fbcc_ros.core.errors import ConfigError

#: The flange of our LBR URDFs: a model with it can be renamed.
OUR_FLANGE = "iiwa_flange"
PEG_LINK = "peg"


def renamed(name: str, prefix: str) -> str:
    """The stack's name for one of our link or joint names (others unchanged)."""
    if name == OUR_FLANGE:
        return f"{prefix}_link_ee"
    if name == f"{OUR_FLANGE}_joint":
        return f"{prefix}_joint_ee"
    if m := re.fullmatch(r"iiwa_link_(\d)", name):
        return f"{prefix}_link_{m[1]}"
    if m := re.fullmatch(r"iiwa_joint_(\d)", name):
        return f"{prefix}_A{m[1]}"
    return name


def lbr_description(urdf: str, prefix: str = "lbr") -> str:
    """The URDF text ``urdf`` of one of our LBR models in the stack's names (``prefix`` is its
    ``robot_name``), without our ``peg`` link (the tool is a parameter of the nodes)."""
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", prefix):
        raise ConfigError("robot_name", prefix, "a name of letters, digits and _ (as lbr)")
    root = ET.fromstring(urdf)
    if root.find(f"link[@name='{OUR_FLANGE}']") is None:
        raise ConfigError("conventions", "lbr", f"a model of the LBR family (its flange "
                          f"'{OUR_FLANGE}'): the stack drives LBRs only")  # fmt: skip
    for joint in root.findall("joint"):
        if joint.find("child").get("link") == PEG_LINK:  # type: ignore[union-attr]
            root.remove(joint)
    for link in root.findall(f"link[@name='{PEG_LINK}']"):
        root.remove(link)
    for element in root.iter():
        if element.tag in ("link", "joint") and "name" in element.attrib:
            element.set("name", renamed(element.get("name", ""), prefix))
        if element.tag in ("parent", "child") and "link" in element.attrib:
            element.set("link", renamed(element.get("link", ""), prefix))
    # the stack's root: a link without inertia (for KDL), fixed to link_0
    floating = f"{prefix}_floating_link"
    root.insert(0, ET.Element("link", name=floating))
    joint = ET.Element("joint", name=f"{prefix}_floating_joint", type="fixed")
    ET.SubElement(joint, "parent", link=floating)
    ET.SubElement(joint, "child", link=f"{prefix}_link_0")
    root.insert(1, joint)
    return ET.tostring(root, encoding="unicode")
