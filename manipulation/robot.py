"""The robot: the KUKA LBR iiwa of ``pybullet_data`` on a 3-dof mobile base, as one URDF.

The base is three joints (prismatic x, prismatic y, revolute yaw) under a
fixed root, so the whole robot is one PyBullet body with a fixed base: IK and
Jacobians then cover all 10 joints directly (a floating base would add six
extra Jacobian columns). A parallel gripper on the flange (:class:`GripperSpec`:
our own model from the published numbers of a Robotiq 2F-85, see
docs/manipulation/README.md#the-gripper) has a housing and two prismatic fingers,
all with collision shapes; a tool link marks the grasp point (tool centre
point), which sits :attr:`GripperSpec.grasp_depth` above the fingertips, so the
fingers close on the top of a knob placed there.
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
FINGER_JOINTS = ("finger_left", "finger_right")
"""The gripper's two fingers: 0 open, ``stroke / 2`` each closed."""
TOOL_LINK = "tool"
BASE_LINK = "base_link"
GRIPPER_LINK = "gripper"
FLANGE_FACE = 0.045
"""Metres from link 7's frame to its flange face (its mesh ends there): the gripper's mount.
(The earlier drawn tool box floated about 4 cm off it.)"""


@dataclass(frozen=True)
class GripperSpec:
    """A parallel gripper with the published numbers of a Robotiq 2F-85 (stroke, force, speed, mass;
    Robotiq's specification sheet) and our own simple geometry (a box housing, two box fingers that
    slide straight: the real fingers swing on a linkage). Lengths in metres."""

    stroke: float = 0.085
    """Opening between the finger pads, fully open (2F-85: 85 mm)."""
    grip_force: float = 235.0
    """Newtons each finger closes with: the 2F-85's largest (20-235 N, set per grasp), so the pads
    hold ``2 x pad_friction x 235 N`` = 470 N along the handle by friction."""
    closing_speed: float = 0.15
    """Metres per second of each finger (2F-85: 20-150 mm/s)."""
    mass: float = 0.925
    """Kilograms, housing and fingers (2F-85: 0.925 kg)."""
    housing: tuple[float, float, float] = (0.06, 0.135, 0.09)
    """Housing (x, y across the fingers' travel, z along the flange axis), from the flange face."""
    finger_length: float = 0.06
    """How far the fingers reach below the housing."""
    finger_thickness: float = 0.01
    """Along the closing direction."""
    finger_width: float = 0.022
    """Pad width, across the closing direction."""
    grasp_depth: float = 0.02
    """How far below the top of a knob the fingertips reach: the pads' grip height."""
    pad_friction: float = 1.0
    """Coulomb friction coefficient of the pads (rubber on a painted knob)."""

    @property
    def tool_offset(self) -> float:
        """Tool centre point beyond the flange face: the top of a grasped knob."""
        return self.housing[2] + self.finger_length - self.grasp_depth


@dataclass(frozen=True)
class RobotSpec:
    """Dimensions of the mobile base and the tool; lengths in metres."""

    base_size: tuple[float, float, float] = (0.42, 0.42, 0.3)
    """Footprint and height of the base box; the arm stands on its top."""
    base_range: float = 15.0
    """Half-width of the square the base may drive in (x and y limits), around the origin."""
    gripper: GripperSpec = GripperSpec()
    arm_torque: tuple[float, ...] = (320.0, 320.0, 176.0, 176.0, 110.0, 40.0, 40.0)
    """N m per arm joint, the most its motor applies (KUKA LBR iiwa 14 R820 datasheet's maximum torques)."""
    arm_speed_deg: tuple[float, ...] = (85.0, 85.0, 100.0, 75.0, 130.0, 135.0, 135.0)
    """Degrees per second per arm joint (KUKA LBR iiwa 14 R820 datasheet)."""
    base_speed: tuple[float, float, float] = (0.5, 0.5, 1.0)
    """m/s (x, y) and rad/s (yaw) the base drives at most: ours, a slow indoor platform (no datasheet)."""
    base_force: tuple[float, float, float] = (1000.0, 1000.0, 400.0)
    """N (x, y) and N m (yaw) the base's velocity controller applies at most: ours."""
    base_gain: float = 10.0
    """Per second: the base's velocity command is this times its position error (plus the feed-forward)."""
    link0_mass: float = 5.0
    """Mass given to the iiwa's link 0 (0 in the model, which PyBullet would treat as static)."""


def speed_limits(spec: RobotSpec) -> tuple[float, ...]:
    """Per robot joint (:data:`ROBOT_JOINTS` order): m/s or rad/s."""
    return (*spec.base_speed, *(math.radians(v) for v in spec.arm_speed_deg))


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
{gripper_urdf(spec.gripper)}"""
    body = "".join(ET.tostring(element, encoding="unicode") for element in arm)
    return head + body + "</robot>\n"


def gripper_urdf(g: GripperSpec) -> str:
    """The gripper's links and joints: the housing on the flange (link 7's frame, z out of the
    flange), the fingers below it closing along y, the tool point between the pads."""
    hx, hy, hz = g.housing
    finger_mass = 0.05
    housing_mass = g.mass - 2 * finger_mass
    finger = (f'<geometry><box size="{g.finger_width} {g.finger_thickness} {g.finger_length}"/></geometry>')
    fingers = ""
    for name, side in ((FINGER_JOINTS[0], 1.0), (FINGER_JOINTS[1], -1.0)):
        y = side * (g.stroke + g.finger_thickness) / 2
        fingers += f"""
  <link name="{name}_link">
    {_box_inertial(finger_mass, (g.finger_width, g.finger_thickness, g.finger_length), g.finger_length / 2)}
    <visual><origin xyz="0 0 {g.finger_length / 2}"/>{finger}<material name="tool_dark"/></visual>
    <collision><origin xyz="0 0 {g.finger_length / 2}"/>{finger}</collision>
  </link>
  <joint name="{name}" type="prismatic"><parent link="{GRIPPER_LINK}"/><child link="{name}_link"/>
    <origin xyz="0 {y} {hz}"/><axis xyz="0 {-side} 0"/>
    <limit lower="0" upper="{g.stroke / 2}" effort="{g.grip_force}" velocity="{g.closing_speed}"/></joint>"""
    return f"""  <link name="{GRIPPER_LINK}">
    {_box_inertial(housing_mass, g.housing, hz / 2)}
    <visual><origin xyz="0 0 {hz / 2}"/><geometry><box size="{hx} {hy} {hz}"/></geometry>
      <material name="tool_dark"/></visual>
    <collision><origin xyz="0 0 {hz / 2}"/><geometry><box size="{hx} {hy} {hz}"/></geometry></collision>
  </link>
  <joint name="gripper_mount" type="fixed"><parent link="lbr_iiwa_link_7"/><child link="{GRIPPER_LINK}"/>
    <origin xyz="0 0 {FLANGE_FACE}"/></joint>{fingers}
  <link name="{TOOL_LINK}">{_inertial(0.001)}</link>
  <joint name="tool_joint" type="fixed"><parent link="{GRIPPER_LINK}"/><child link="{TOOL_LINK}"/>
    <origin xyz="0 0 {g.tool_offset}"/></joint>
"""


def _box_inertial(mass: float, size: tuple[float, float, float], z: float) -> str:
    x2, y2, z2 = (v * v for v in size)
    m = mass / 12.0
    return (f'<inertial><origin xyz="0 0 {z}"/><mass value="{mass}"/>'
            f'<inertia ixx="{m * (y2 + z2)}" ixy="0" ixz="0" iyy="{m * (x2 + z2)}" iyz="0" izz="{m * (x2 + y2)}"/>'
            '</inertial>')


def _inertial(mass: float) -> str:
    return (f'<inertial><mass value="{mass}"/>'
            f'<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>')
