"""MJCF export: the file loads in MuJoCo, its joints are the URDF's, and the certificate holds there.

MuJoCo is a third implementation of the same geometry (after our collision
model and PyBullet): the certificate, replayed densely in the exported MJCF
by setting ``qpos`` and running ``mj_forward``, must show no contact between
geoms of different objects deeper than :data:`PENETRATION_THRESHOLD`.
"""

from __future__ import annotations

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from phyrogen.cli import main  # noqa: E402
from phyrogen_core.chain import JointType, Role  # noqa: E402
from phyrogen_core.export import (  # noqa: E402
    chain_to_mjcf,
    mjcf_path,
    read_puzzle_dir,
    read_urdf,
    write_puzzle,
)
from phyrogen_core.export.mjcf import object_of_link  # noqa: E402
from phyrogen_core.folder import PuzzleFolder  # noqa: E402

PENETRATION_THRESHOLD = 1e-3
"""Metres. Puzzle shapes touch at rest (our model counts touching as free within 1e-6 m); MuJoCo
reports a touching pair as a contact with a distance of about zero. One millimetre, the PyBullet
referee's threshold, separates touching from a real overlap, which is centimetres deep."""
REPLAY_RESOLUTION = 0.002
"""Metres any collision point moves between replayed states: the certificate check's 2 mm."""

# Seeds 8300-8399 are used by no other test. Sizes that follow the seed are set explicitly.
PUZZLES = [
    ("lockbox_random", 8310, {}),  # revolute slot discs: inline meshes
    ("move_n_times", 8311, {"n": 2}),  # an SE(2) target: x, y, yaw with helper bodies
    ("rooms", 8312, {}),  # SE(2) (x, y) target, revolute doors, many static walls
    ("simple_slider", 8313, {"n_objects": 3}),
    ("grid_world", 8314, {}),
    ("continuous_space", 8315, {}),
]
NAMES = [f"{generator}_{seed}" for generator, seed, _ in PUZZLES]


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """name -> (puzzle, folder): the puzzles written as folders, then `phyrogen export --format mjcf` on their root."""
    from phyrogen_core.registry import get_generator
    from solver.pipelines.generation import generate_here

    root = tmp_path_factory.mktemp("mjcf")
    out = {}
    for generator, seed, overrides in PUZZLES:
        puzzle = generate_here(generator, seed, get_generator(generator).parse_params(overrides))
        out[puzzle.name] = (puzzle, write_puzzle(puzzle, root))
    urdf_before = {name: PuzzleFolder(folder, name).urdf.read_bytes() for name, (_, folder) in out.items()}
    assert main(["export", str(root), "--format", "mjcf"]) == 0
    for name, (_, folder) in out.items():  # the export stage's files are untouched
        assert PuzzleFolder(folder, name).urdf.read_bytes() == urdf_before[name]
    return out


def _model(exported, name):
    puzzle, folder = exported[name]
    path = mjcf_path(folder, name)
    assert path.is_file()
    model = mujoco.MjModel.from_xml_path(str(path))
    return puzzle, folder, model, mujoco.MjData(model)


def _set_state(model, data, joint_order, state) -> None:
    """Place the bodies at ``state`` and find their contacts (no dynamics: the constraint solver the
    file asks for costs 7x more per state on overlapping shapes, and a replay needs only geometry)."""
    for joint_name, value in zip(joint_order, state, strict=True):
        data.qpos[model.jnt_qposadr[model.joint(joint_name).id]] = value
    mujoco.mj_kinematics(model, data)
    mujoco.mj_collision(model, data)


def _deepest_between_objects(model, data, chain) -> tuple[float, tuple[str, str]]:
    """The deepest contact (metres, >= 0) between geoms of different objects, and the two bodies."""
    deepest, between = 0.0, ()
    for contact in data.contact[:data.ncon]:
        a, b = (model.body(model.geom_bodyid[g]).name for g in (contact.geom1, contact.geom2))
        if object_of_link(chain.link(a)) != object_of_link(chain.link(b)) and -contact.dist > deepest:
            deepest, between = -float(contact.dist), (a, b)
    return deepest, between


def _dense(chain, states) -> np.ndarray:
    from solver.collision.model import CollisionModel
    from solver.planning.problem import segment_points

    states = np.asarray(states, dtype=float)
    steps = CollisionModel(chain).motion_steps(REPLAY_RESOLUTION)
    return np.concatenate([states[:1], segment_points(states, steps)[0]]) if len(states) > 1 else states


@pytest.mark.parametrize("name", NAMES)
def test_joints_are_the_urdfs(exported, name):
    puzzle, folder, model, data = _model(exported, name)
    urdf_chain = read_urdf(PuzzleFolder(folder, name).urdf, root=folder)
    joints = urdf_chain.active_joints
    assert model.njnt == len(joints) and model.nq == len(joints)
    kinds = {JointType.PRISMATIC: mujoco.mjtJoint.mjJNT_SLIDE, JointType.REVOLUTE: mujoco.mjtJoint.mjJNT_HINGE}
    for joint in joints:
        mj = model.joint(joint.name)
        assert model.jnt_type[mj.id] == kinds[joint.type], joint.name
        assert model.jnt_limited[mj.id], joint.name
        # Exact: both files spell the same shortest round-tripping decimals.
        assert tuple(model.jnt_range[mj.id]) == (joint.lower, joint.upper), joint.name
        assert tuple(model.jnt_axis[mj.id]) == tuple(joint.axis), joint.name
    # Every body sits where the chain puts its link, at random states within the limits.
    rng = np.random.default_rng(8316)
    for _ in range(5):
        state = rng.uniform(urdf_chain.lower_limits, urdf_chain.upper_limits)
        _set_state(model, data, urdf_chain.joint_order, state)
        for link_name, transform in puzzle.chain.link_transforms(state).items():
            body = data.body(link_name)
            assert np.allclose(body.xpos, transform[:3, 3], atol=1e-9), link_name
            assert np.allclose(body.xmat.reshape(3, 3), transform[:3, :3], atol=1e-9), link_name


@pytest.mark.parametrize("name", NAMES)
def test_certificate_replayed_in_mujoco_penetrates_nothing(exported, name, record_property):
    puzzle, _, model, data = _model(exported, name)
    dense = _dense(puzzle.chain, puzzle.certificate)
    deepest, between, contacts = 0.0, (), 0
    for state in dense:
        _set_state(model, data, puzzle.joint_order, state)
        contacts += data.ncon
        depth, pair = _deepest_between_objects(model, data, puzzle.chain)
        if depth > deepest:
            deepest, between = depth, pair
    record_property("max_penetration_m", deepest)
    record_property("replayed_states", len(dense))
    assert len(dense) > len(puzzle.certificate)
    assert deepest < PENETRATION_THRESHOLD, f"{name}: {deepest * 1000:.3f} mm between {between}"


@pytest.mark.parametrize("name", NAMES)
def test_the_replay_sees_a_real_overlap(exported, name):
    """The measure is not vacuous: straight from start to goal runs through a blocker, which our
    model reports and MuJoCo measures deeper than the threshold."""
    from solver.collision.model import CollisionModel

    puzzle, _, model, data = _model(exported, name)
    line = _dense(puzzle.chain, [puzzle.certificate[0], puzzle.certificate[-1]])
    assert not CollisionModel(puzzle.chain).check(line).all()
    deepest = 0.0
    for state in line:
        _set_state(model, data, puzzle.joint_order, state)
        deepest = max(deepest, _deepest_between_objects(model, data, puzzle.chain)[0])
    assert deepest > PENETRATION_THRESHOLD


@pytest.mark.parametrize("name", NAMES)
def test_geometry_colours_and_goal_site(exported, name):
    puzzle, _, model, _ = _model(exported, name)
    chain = puzzle.chain
    visual_group, collision_group = 2, 3
    for geom_id in range(model.ngeom):
        if model.geom_bodyid[geom_id] == 0:  # the floor, in the world body (test_dynamics_are_written)
            continue
        link = chain.link(model.body(model.geom_bodyid[geom_id]).name)
        colliding = model.geom_contype[geom_id] or model.geom_conaffinity[geom_id]
        assert link.role is not Role.GOAL_MARKER or not colliding
        assert model.geom_group[geom_id] == (collision_group if colliding else visual_group)
    for link in chain.links:
        body = model.body(link.name)
        geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body.id]
        collision = [g for g in geoms if model.geom_contype[g]]
        visual = [g for g in geoms if not model.geom_contype[g]]
        if link.role is Role.GOAL_MARKER:
            sites = [s for s in range(model.nsite) if model.site_bodyid[s] == body.id]
            assert len(sites) == len(link.visuals) and not geoms
            for site, geometry in zip(sites, link.visuals, strict=True):
                assert tuple(model.mat_rgba[model.site_matid[site]]) == pytest.approx(geometry.color)
            continue
        pieces = [len(g.shape.pieces) if hasattr(g.shape, "pieces") else 1 for g in link.collisions]
        assert len(collision) == sum(pieces), link.name
        expected = [g.color for g in link.visuals for _ in range(len(getattr(g.shape, "pieces", (0,))))]
        shown = [model.mat_rgba[model.geom_matid[g]] for g in visual]
        assert np.allclose(np.reshape(shown, (-1, 4)), np.reshape(expected, (-1, 4))), link.name
    if name.startswith("lockbox_random"):  # the slot discs: one convex mesh per piece, visual and collision
        assert model.nmesh > 0
        assert any(model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH and model.geom_contype[g]
                   for g in range(model.ngeom))


@pytest.mark.parametrize("name", NAMES)
def test_mjcf_is_byte_deterministic(exported, name):
    puzzle, folder = exported[name]
    text = chain_to_mjcf(puzzle.chain, puzzle.certificate)
    assert text == chain_to_mjcf(puzzle.chain, puzzle.certificate)
    assert mjcf_path(folder, name).read_bytes() == text.encode("utf-8")
    # The chain read back from the folder (URDF + puzzle.json) gives the same bytes.
    loaded = read_puzzle_dir(folder)
    assert chain_to_mjcf(loaded.chain, loaded.certificate) == text


def test_export_again_replaces_the_file_atomically(exported, tmp_path, capsys):
    name = NAMES[0]
    _, folder = exported[name]
    path = mjcf_path(folder, name)
    before = path.read_bytes()
    (path.parent / "stray.txt").write_text("no file of the export's: a user's, kept")
    assert main(["export", str(folder), "--format", "mjcf"]) == 0
    assert str(path) in capsys.readouterr().out
    assert path.read_bytes() == before
    # Only the export's own file is replaced (tests/test_hostile_user_files.py).
    assert sorted(p.name for p in path.parent.iterdir()) == sorted([path.name, "stray.txt"])
    assert not [p for p in folder.iterdir() if p.name.startswith(".")]  # no temporary left behind


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["export", "{out}/missing", "--format", "mjcf"], "missing"),
        (["export", "{good}", "{out}/missing", "--format", "mjcf"], "missing"),
        (["export", "{good}", "--format", "urdf"], "invalid choice"),
        (["export", "{out}", "--format", "mjcf"], "no puzzle folders"),
    ],
)
def test_bad_input_is_one_line_exit_2_and_writes_nothing(exported, argv, message, tmp_path, capsys):
    import shutil

    _, folder = exported[NAMES[-1]]
    good = tmp_path / "good"
    shutil.copytree(folder, good, ignore=shutil.ignore_patterns("mjcf"))
    out = tmp_path / "out"
    out.mkdir()
    capsys.readouterr()
    code = main([a.replace("{out}", str(out)).replace("{good}", str(good)) for a in argv])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and message in err, err
    assert not (good / "mjcf").exists()


def _mounted_chain():
    """An object ("door": two links, a hinge and a leaf fixed to it) carrying another object (a
    slider mounted on the leaf), and a goal marker with a prism outline."""
    from phyrogen_core.chain import Geometry, Joint, KinematicChain, Link
    from phyrogen_core.geometry import Box, Pose, slot_disc

    box = (Geometry(Box((1.0, 0.2, 0.2))),)
    links = (
        Link("base_link", role=Role.BASE, mass=0.0),
        Link("hinge", box, box, Role.BLOCKER, "door"),
        Link("leaf", box, box, Role.BLOCKER, "door"),
        Link("slider", box, box, Role.TARGET, "slider"),
        Link("goal", (Geometry(slot_disc(0.3, 0.1)),), (), Role.GOAL_MARKER, "goal", 0.01),
    )
    joints = (
        Joint("door", JointType.REVOLUTE, "base_link", "hinge", Pose.planar(0, 0, 0.1), lower=-1.0, upper=1.0),
        Joint("leaf", JointType.FIXED, "hinge", "leaf", Pose.planar(1.0, 0, 0)),
        Joint("slider", JointType.PRISMATIC, "leaf", "slider", Pose.planar(0, 1.0, 0), (0.0, 1.0, 0.0), -2.0, 0.0),
        Joint("goal", JointType.FIXED, "base_link", "goal", Pose.planar(3, 3, 0.1)),
    )
    return KinematicChain(links, joints, name="mounted")


def test_contacts_follow_objects_not_bodies():
    """Links of one object never collide; an object mounted on another collides with it although
    its body is the other's child (MuJoCo's parent filter is off); the goal never collides."""
    chain = _mounted_chain()
    text = chain_to_mjcf(chain)
    assert '<exclude body1="hinge" body2="leaf"/>' in text
    model = mujoco.MjModel.from_xml_string(text)
    # Without a certificate (None or no states): servos on both joints, no keyframes.
    assert model.nu == 2 and model.nkey == 0 and chain_to_mjcf(chain, ()) == text
    data = mujoco.MjData(model)
    goal = model.body("goal").id
    assert all(not model.geom_contype[g] and not model.geom_conaffinity[g]
               for g in range(model.ngeom) if model.geom_bodyid[g] == goal)
    _set_state(model, data, chain.joint_order, [0.0, 0.0])  # hinge and leaf touch end to end: no contact
    assert _deepest_between_objects(model, data, chain)[0] == 0.0
    assert not any({model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2]} == {model.body("hinge").id,
                   model.body("leaf").id} for c in data.contact[:data.ncon])
    _set_state(model, data, chain.joint_order, [0.0, -1.0])  # the slider pushed into the leaf, its parent
    depth, between = _deepest_between_objects(model, data, chain)
    assert depth == pytest.approx(0.2) and set(between) == {"leaf", "slider"}


def test_generate_writes_the_mjcf_beside_the_urdf_on_request(tmp_path, capsys):
    argv = ["generate", "--generator", "simple_slider", "--seed", "8316", "--set", "n_objects=2", "--quiet"]
    assert main([*argv, "--out", str(tmp_path / "plain")]) == 0
    assert main([*argv, "--mjcf", "--out", str(tmp_path / "with")]) == 0
    capsys.readouterr()
    plain = tmp_path / "plain" / "simple_slider" / "simple_slider_8316"
    folder = tmp_path / "with" / "simple_slider" / "simple_slider_8316"
    assert not mjcf_path(plain, "simple_slider_8316").exists()
    written = mjcf_path(folder, "simple_slider_8316").read_bytes()
    loaded = read_puzzle_dir(folder)
    assert written == chain_to_mjcf(loaded.chain, loaded.certificate).encode("utf-8")
    assert PuzzleFolder(folder, "simple_slider_8316").urdf.read_bytes() == \
        PuzzleFolder(plain, "simple_slider_8316").urdf.read_bytes()
    mujoco.MjModel.from_xml_path(str(mjcf_path(folder, "simple_slider_8316")))


# -- dynamics: friction, damping, servos, floor, keyframes, and rollouts through the servos ---------------------

ROLLOUT_PUZZLES = [
    ("lockbox_random", 8330, {}),
    ("move_n_times", 8331, {"n": 3}),
    ("rooms", 8332, {}),
    ("simple_slider", 8333, {"n_objects": 4}),
    ("grid_world", 8334, {}),
    ("continuous_space", 8335, {}),
]
"""More fresh seeds (no other test uses 8330-8339), rolled out from their MJCF text beside the exported six."""


@pytest.fixture(scope="module")
def rollout_puzzles(exported):
    """name -> (puzzle, MJCF text): the exported files and the second set of seeds."""
    from phyrogen_core.registry import get_generator
    from solver.pipelines.generation import generate_here

    out = {name: (puzzle, mjcf_path(folder, name).read_text()) for name, (puzzle, folder) in exported.items()}
    for generator, seed, overrides in ROLLOUT_PUZZLES:
        puzzle = generate_here(generator, seed, get_generator(generator).parse_params(overrides))
        out[puzzle.name] = (puzzle, chain_to_mjcf(puzzle.chain, puzzle.certificate))
    return out


ROLLOUT_NAMES = NAMES + [f"{generator}_{seed}" for generator, seed, _ in ROLLOUT_PUZZLES]


@pytest.mark.parametrize("name", NAMES)
def test_dynamics_are_written(exported, name):
    """Every movable joint has friction, damping and a force-limited position servo; the keyframes
    are the certificate's ends; the floor lies under the puzzle and never touches it."""
    from phyrogen_core.export.mjcf_dynamics import DYNAMICS, GRAVITY

    puzzle, _, model, data = _model(exported, name)
    chain = puzzle.chain
    assert model.opt.timestep == DYNAMICS.timestep and model.nu == len(chain.joint_order)
    for joint in chain.active_joints:
        dof = model.jnt_dofadr[model.joint(joint.name).id]
        actuator = model.actuator(joint.name)
        moved = chain.link(joint.child).mass  # every generator's object is one link of 1 kg (helpers 0.01)
        arm = DYNAMICS.bearing_radius if joint.type is JointType.REVOLUTE else 1.0
        assert model.dof_damping[dof] > 0
        assert model.dof_frictionloss[dof] >= DYNAMICS.joint_friction * moved * GRAVITY * arm * (1 - 1e-12)
        assert model.actuator_trnid[actuator.id, 0] == model.joint(joint.name).id
        assert model.actuator_gainprm[actuator.id, 0] > 0 and model.actuator_forcelimited[actuator.id]
        limit = model.actuator_forcerange[actuator.id]
        assert limit[0] == -limit[1] and (limit[1] == DYNAMICS.servo_force if joint.type is JointType.PRISMATIC
                                          else limit[1] > 0)
        assert tuple(model.actuator_ctrlrange[actuator.id]) == (joint.lower, joint.upper)
    for key, state in (("start", puzzle.certificate[0]), ("goal", puzzle.certificate[-1])):
        mujoco.mj_resetDataKeyframe(model, data, model.key(key).id)
        for joint_name, value in zip(chain.joint_order, state, strict=True):
            assert data.joint(joint_name).qpos[0] == value and data.actuator(joint_name).ctrl[0] == value
    floor = model.geom("floor")
    assert model.geom_type[floor.id] == mujoco.mjtGeom.mjGEOM_PLANE
    mujoco.mj_resetDataKeyframe(model, data, model.key("start").id)
    mujoco.mj_forward(model, data)
    puzzle_geoms = [g for g in range(model.ngeom) if g != floor.id and model.geom_contype[g]]
    assert all(not (model.geom_contype[floor.id] & model.geom_conaffinity[g])
               and not (model.geom_contype[g] & model.geom_conaffinity[floor.id]) for g in puzzle_geoms)
    lowest = min(data.geom_xpos[g][2] - model.geom_rbound[g] for g in puzzle_geoms)
    assert model.geom_pos[floor.id][2] >= lowest - 1e-9  # under the puzzle's lowest shape, not below its bound


def test_a_body_a_user_adds_rests_on_the_floor(exported):
    """The floor is real for anything but the puzzle: a free box with MuJoCo's default collision bits,
    dropped on it, comes to rest on it (not through it)."""
    puzzle, folder = exported[NAMES[3]]
    text = mjcf_path(folder, NAMES[3]).read_text()
    model = mujoco.MjModel.from_xml_string(text)
    floor_z = float(model.geom_pos[model.geom("floor").id][2])
    away = 50.0  # far from the puzzle
    box = (f'<body name="user_box" pos="{away} {away} {floor_z + 0.5}"><freejoint/>'
           '<inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/><geom type="box" size="0.1 0.1 0.1"/></body>')
    model = mujoco.MjModel.from_xml_string(text.replace("  </worldbody>", f"    {box}\n  </worldbody>"))
    data = mujoco.MjData(model)
    for _ in range(2000):
        mujoco.mj_step(model, data)
    assert data.body("user_box").xpos[2] == pytest.approx(floor_z + 0.1, abs=1e-3)


@pytest.mark.parametrize("name", ROLLOUT_NAMES)
def test_driving_the_servos_along_the_certificate_reaches_the_goal(rollout_puzzles, name, record_property):
    from manipulation.mjcf_rollout import DRIVE_DEPTH, drive_certificate

    puzzle, text = rollout_puzzles[name]
    drive = drive_certificate(text, puzzle.chain, puzzle.certificate, puzzle.goal)
    record_property("deepest_m", drive.deepest)
    assert drive.reached, f"{name}: {drive.goal_error} from the goal after {drive.steps} steps"
    assert drive.deepest < DRIVE_DEPTH, f"{name}: {drive.deepest * 1000:.3f} mm between {drive.between}"
    # Negative control: the same drive straight from start to goal (through the blockers) does not get there.
    straight = _straight_to_goal(puzzle)
    bad = drive_certificate(text, puzzle.chain, [puzzle.certificate[0], straight], puzzle.goal)
    assert not bad.reached or bad.deepest >= DRIVE_DEPTH, f"{name}: the straight line passed"


@pytest.mark.parametrize("name", ROLLOUT_NAMES)
def test_a_push_straight_to_the_goal_is_stopped(rollout_puzzles, name, record_property):
    from manipulation.mjcf_rollout import BLOCKER_STILL, PUSH_DEPTH, push_target

    puzzle, text = rollout_puzzles[name]
    push = push_target(text, puzzle.chain, puzzle.certificate, puzzle.goal)
    record_property("deepest_m", push.deepest)
    assert push.touched and not push.reached
    assert push.deepest < PUSH_DEPTH, f"{name}: {push.deepest * 1000:.3f} mm between {push.between}"
    assert push.others_moved < BLOCKER_STILL, f"{name}: a held part moved {push.others_moved * 1000:.2f} mm"
    # Control: with contacts off the same servo carries the target well past where it stopped.
    free = push_target(text, puzzle.chain, puzzle.certificate, puzzle.goal, contacts=False)
    assert free.target_moved > push.target_moved + 10 * PUSH_DEPTH


def _straight_to_goal(puzzle) -> list[float]:
    state = list(puzzle.certificate[0])
    for joint_name, value in puzzle.goal.values.items():
        state[puzzle.joint_order.index(joint_name)] = value
    return state
