"""The robot: the KUKA LBR iiwa of ``pybullet_data`` on a 3-dof mobile base, as one URDF.

The base is three joints (prismatic x, prismatic y, revolute yaw) under a
fixed root, so the whole robot is one PyBullet body with a fixed base: IK and
Jacobians then cover all 10 joints directly (a floating base would add six
extra Jacobian columns). A tool link on the flange marks the grasp point
(tool centre point); it has a visual gripper but no collision shape, because
during a grasp it sits on the knob by design.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import pybullet_data

BASE_JOINTS = ("base_x", "base_y", "base_yaw")
ARM_JOINTS = tuple(f"lbr_iiwa_joint_{i}" for i in range(1, 8))
ROBOT_JOINTS = BASE_JOINTS + ARM_JOINTS
TOOL_LINK = "tool"
BASE_LINK = "base_link"


@dataclass(frozen=True)
class RobotSpec:
    """Dimensions of the mobile base and the tool; lengths in metres."""

    base_size: tuple[float, float, float] = (0.42, 0.42, 0.3)
    """Footprint and height of the base box; the arm stands on its top."""
    base_range: float = 15.0
    """Half-width of the square the base may drive in (x and y limits), around the origin."""
    tool_offset: float = 0.07
    """Tool centre point beyond the flange frame (link 7 ends 0.048 past it)."""
    link0_mass: float = 5.0
    """Mass given to the iiwa's link 0 (0 in the model, which PyBullet would treat as static)."""


ARM_REST = (0.0, 0.5, 0.0, -1.6, 0.0, 1.0, 0.0)
"""A comfortable arm pose (elbow up, tool down in front), used as IK rest pose and home."""
ARM_TUCKED = (0.0,) * 7
"""The arm straight up, inside the base's footprint: how the robot drives long ways."""


def iiwa_urdf_path() -> Path:
    return Path(pybullet_data.getDataPath()) / "kuka_iiwa" / "model.urdf"


def mobile_iiwa_urdf(spec: RobotSpec = RobotSpec()) -> str:
    """URDF text of the iiwa on the mobile base (mesh paths absolute into ``pybullet_data``)."""
    source = iiwa_urdf_path()
    arm = ET.parse(source).getroot()
    mesh_dir = source.parent
    for mesh in arm.iter("mesh"):
        mesh.set("filename", str(mesh_dir / mesh.get("filename", "")))
    for link in arm.findall("link"):
        if link.get("name") == "lbr_iiwa_link_0":
            mass = link.find("inertial/mass")
            if mass is not None:
                mass.set("value", str(spec.link0_mass))
    sx, sy, sz = spec.base_size
    r = spec.base_range
    head = f"""<?xml version="1.0"?>
<robot name="mobile_iiwa">
  <material name="base_gray"><color rgba="0.25 0.25 0.3 1"/></material>
  <material name="tool_dark"><color rgba="0.15 0.15 0.15 1"/></material>
  <link name="world"/>
  <link name="base_x_link">{_inertial(0.1)}</link>
  <link name="base_y_link">{_inertial(0.1)}</link>
  <link name="{BASE_LINK}">
    {_inertial(20.0)}
    <visual><origin xyz="0 0 {sz / 2}"/><geometry><box size="{sx} {sy} {sz}"/></geometry>
      <material name="base_gray"/></visual>
    <collision><origin xyz="0 0 {sz / 2}"/><geometry><box size="{sx} {sy} {sz}"/></geometry></collision>
  </link>
  <joint name="base_x" type="prismatic"><parent link="world"/><child link="base_x_link"/>
    <axis xyz="1 0 0"/><limit lower="{-r}" upper="{r}" effort="5000" velocity="2"/></joint>
  <joint name="base_y" type="prismatic"><parent link="base_x_link"/><child link="base_y_link"/>
    <axis xyz="0 1 0"/><limit lower="{-r}" upper="{r}" effort="5000" velocity="2"/></joint>
  <joint name="base_yaw" type="revolute"><parent link="base_y_link"/><child link="{BASE_LINK}"/>
    <axis xyz="0 0 1"/><limit lower="{-2 * math.pi}" upper="{2 * math.pi}" effort="5000" velocity="2"/></joint>
  <joint name="base_to_arm" type="fixed"><parent link="{BASE_LINK}"/><child link="lbr_iiwa_link_0"/>
    <origin xyz="0 0 {sz}"/></joint>
  <link name="{TOOL_LINK}">
    {_inertial(0.05)}
    <visual><origin xyz="0 0 {spec.tool_offset - 0.035}"/><geometry><box size="0.03 0.09 0.03"/></geometry>
      <material name="tool_dark"/></visual>
  </link>
  <joint name="tool_joint" type="fixed"><parent link="lbr_iiwa_link_7"/><child link="{TOOL_LINK}"/>
    <origin xyz="0 0 {spec.tool_offset}"/></joint>
"""
    body = "".join(ET.tostring(element, encoding="unicode") for element in arm)
    return head + body + "</robot>\n"


def _inertial(mass: float) -> str:
    return (f'<inertial><mass value="{mass}"/>'
            f'<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>')
