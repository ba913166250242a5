"""The pictures beside the data (a colour copy of the label image, --no-picture) and what a
command says when it will not overwrite."""

import cv2
import numpy as np

from maps.sim.floorplan import generate_floor_plan
from topomap.cli.main import main


def test_segment_writes_a_colour_picture_beside_the_labels_and_can_skip_drawing(tmp_path):
    generate_floor_plan("flat", random_state=0).grid.save(tmp_path / "map.yaml")
    out = tmp_path / "out"
    argv = ["-q", "segment", str(tmp_path / "map.yaml"), "--out", str(out), "--no-picture"]
    assert main(argv) == 0
    assert not (out / "segmentation.png").exists()
    labels = cv2.imread(str(out / "regions.png"), cv2.IMREAD_UNCHANGED)
    colour = cv2.imread(str(out / "regions_colour.png"), cv2.IMREAD_COLOR)
    assert labels.dtype == np.uint16 and colour.shape == (*labels.shape, 3)
    pairs = np.unique(np.column_stack([labels.ravel(), colour.reshape(-1, 3)]), axis=0)
    # one colour per region and one region per colour; no region is grey
    assert len(pairs) == len(np.unique(labels)) == len(np.unique(pairs[:, 1:], axis=0))
    assert pairs[pairs[:, 0] == 0, 1:].tolist() == [[235, 235, 235]]
    assert main(["-q", "map", "nothing.log", "--out", str(tmp_path / "m"), "--no-picture"]) == 2


def test_export_names_the_command_line_flag_when_it_refuses_to_overwrite(tmp_path, capsys):
    from topomap.topomap import TopoMap

    plan = generate_floor_plan((16.0, 12.0), random_state=1)
    plan.grid.save(tmp_path / "map.yaml")
    TopoMap.from_grid(plan.grid, random_state=1).save(tmp_path / "regions")
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("kept\n")
    argv = ["export", str(tmp_path / "map.yaml"), "--regions", str(tmp_path / "regions")]
    assert main([*argv, "--rosbag", str(bag)]) == 2
    error = capsys.readouterr().err
    assert "--force" in error and "overwrite=True" not in error
    assert (bag / "metadata.yaml").read_text() == "kept\n"
