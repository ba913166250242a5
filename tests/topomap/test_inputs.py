"""Inputs are recognised in one place: ``segment``/``map`` and ``batch`` agree on a bag."""

from pathlib import Path

from topomap.cli.commands.common import read_as_bag
from topomap.cli.inputs import find_inputs, input_kind


def test_the_command_line_and_batch_agree_on_what_a_bag_is(tmp_path: Path):
    for name in ("ros1.bag", "alone_0.mcap", "alone_0.db3", "run.log.gz", "notes.txt"):
        (tmp_path / name).write_bytes(b"")
    (tmp_path / "ros2").mkdir()
    (tmp_path / "ros2" / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    (tmp_path / "ros2" / "ros2_0.mcap").write_bytes(b"")
    (tmp_path / "map.yaml").write_text("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    kinds = {job.name: job.kind for job in find_inputs([str(tmp_path)])}
    assert kinds == {
        "ros1": "bag",
        "alone_0.mcap": "bag",  # two inputs of one stem: named by their files
        "alone_0.db3": "bag",
        "ros2": "bag",  # one input, not its storage file too
        "run": "log",
        "map": "map",
    }
    for path in tmp_path.iterdir():
        if path.is_file():
            assert read_as_bag(path) == (input_kind(path) == "bag"), path.name
