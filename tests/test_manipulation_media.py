"""Manipulation media: four 640x480 frames and an MP4, each showing the robot and the puzzle together."""

from __future__ import annotations

import numpy as np
import pytest

SIZE = (640, 480)


def _in_frame(segmentation: np.ndarray, body: int) -> bool:
    """``body`` is seen, and none of its pixels touches the image border."""
    mask = segmentation == body
    border = np.concatenate([mask[0], mask[-1], mask[:, 0], mask[:, -1]])
    return bool(mask.any()) and not border.any()


@pytest.fixture(scope="module")
def executed(tmp_path_factory):
    from manipulation.execution import execute_puzzle
    from phyrogen_core.export import write_puzzle
    from solver.pipelines.generation import generate_puzzle

    root = tmp_path_factory.mktemp("media")
    puzzle = generate_puzzle("simple_slider", 9173, {"n_objects": 2})
    report, recording, setup = execute_puzzle(write_puzzle(puzzle, root / "puzzles"))
    assert report.success, report.message
    return root, report, recording, setup


def test_four_frames_show_the_robot_and_the_puzzle_in_frame(executed):
    from manipulation.media import Renderer, figure_pictures

    _, _, recording, setup = executed
    with Renderer(setup) as renderer:
        pictures = figure_pictures(renderer, recording)
        robot, puzzle = renderer.world.robot, renderer.world.puzzle
    assert len(pictures) == 4
    for number, picture in enumerate(pictures, start=1):
        assert picture.rgb.shape == (SIZE[1], SIZE[0], 3)
        assert _in_frame(picture.segmentation, robot), f"frame {number}: the robot is cut off or missing"
        assert _in_frame(picture.segmentation, puzzle), f"frame {number}: the puzzle is cut off or missing"


def test_outputs_hold_four_640x480_frames_and_a_decodable_640x480_video(executed):
    import imageio.v2 as imageio

    from manipulation.media import Renderer, video_cameras, video_indices
    from manipulation.outputs import write_outputs

    root, report, recording, setup = executed
    out = write_outputs(root / "out", report, recording, setup, video=True)
    frames = sorted((out / "frames").glob("frame_*.png"))
    assert [f.name for f in frames] == [f"frame_{i}.png" for i in range(1, 5)]
    for frame in frames:
        assert imageio.imread(frame).shape[:2] == (SIZE[1], SIZE[0])
    reader = imageio.get_reader(out / f"{report.puzzle}.mp4")
    try:
        decoded = [frame.shape for frame in reader]
    finally:
        reader.close()
    assert len(decoded) == len(video_indices(recording)) > 10
    assert all(shape[:2] == (SIZE[1], SIZE[0]) for shape in decoded)

    # The video's smoothed camera keeps both bodies in frame too.
    from manipulation.media import VIDEO_SIZE
    indices = video_indices(recording)
    with Renderer(setup) as renderer:
        cameras = video_cameras(renderer, recording, indices)
        for index, camera in list(zip(indices, cameras, strict=True))[::5]:
            seg = renderer.picture(recording, index, VIDEO_SIZE, camera).segmentation
            assert _in_frame(seg, renderer.world.robot) and _in_frame(seg, renderer.world.puzzle), index
