"""Fuzz the readers and writers with generated bad input (issue 24) and print the counts.

    .venv/bin/python tests/fuzz.py --cases 3000

Each case is a map YAML, an image header, a CARMEN line, a cut or flipped ROS 1 bag, or a write
over a user's file. A case is a *crash* when anything but a ``TopomapError`` escapes, a *hang*
when it takes more than ``--hang`` seconds, *silent* when it reads without error but breaks
what the input says (a white PGM pixel not free, a pose not the one written), *lost* when a
file that was there changed without ``overwrite``. Zero of each is the bar; exit status 1
otherwise.
"""

from __future__ import annotations

import argparse
import random
import signal
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from maps.carmen import read_carmen
from maps.errors import TopomapError
from maps.files import write_text
from maps.grid import FREE
from maps.map_server import load_map, read_image
from maps.rosbag import read_rosbag

NUMBERS = [
    "0",
    "-1",
    "1e-8",
    "1e300",
    "nan",
    ".inf",
    "1" + "0" * 400,
    "1" * 5000,  # over Python's 4300 digits for reading an integer
    "*bomb",  # nine to the twelfth items if the alias below were expanded
    "0.05",
    "[1, 2]",
    "abc",
    "{}",
]


class SilentError(Exception):
    """A read that succeeded but contradicts its input."""


class LostFileError(Exception):
    """A user's file changed without ``overwrite``."""


def _yaml_case(rng: random.Random, folder: Path) -> None:
    maxval = rng.choice([1, 100, 255, 1000, 65535])
    wide = maxval > 255
    white = maxval.to_bytes(2 if wide else 1, "big")
    (folder / "img.pgm").write_bytes(f"P5\n1 1\n{maxval}\n".encode() + white)
    fields = {"image": "img.pgm", "resolution": "0.05", "origin": "[0, 0, 0]", "negate": "0"}
    fields |= {"occupied_thresh": "0.65", "free_thresh": "0.196"}
    for _ in range(rng.randrange(3)):
        fields[rng.choice(sorted(fields))] = rng.choice(NUMBERS)
    if rng.random() < 0.05:
        fields["origin"] = "[" * 5000 + "]" * 5000
    path = folder / "map.yaml"
    levels = [
        f"l{i}: &{'bomb' if i == 12 else f'l{i}'} ["
        + ", ".join(["x" if i == 0 else f"*l{i - 1}"] * 9)
        + "]\n"
        for i in range(13)
    ]
    bomb = "".join(levels) if "*bomb" in fields.values() else ""
    path.write_text(bomb + "".join(f"{k}: {v}\n" for k, v in fields.items()))
    grid = load_map(path)
    if fields["negate"] == "0" and fields["free_thresh"] == "0.196" and grid.cells[0, 0] != FREE:
        raise SilentError(f"a white pixel of maxval {maxval} is not free")


def _image_case(rng: random.Random, folder: Path) -> None:
    width, height = (rng.choice([0, 1, 3, 10**5, 2 * 10**9, 10**12]) for _ in range(2))
    maxval = rng.choice([0, 1, 255, 256, 65535, 70000])
    body = bytes(rng.randrange(256) for _ in range(rng.randrange(16)))
    path = folder / "img.pgm"
    path.write_bytes(
        f"{rng.choice(['P2', 'P5', 'P6'])}\n{width} {height}\n{maxval}\n".encode() + body
    )
    pixels = read_image(path)
    if pixels.shape[:2] != (height, width):
        raise SilentError(f"{width} x {height} header read as {pixels.shape}")


def _log_case(rng: random.Random, folder: Path) -> None:
    n = rng.randrange(1, 6)
    ranges = [f"{rng.uniform(0.1, 9):.2f}" for _ in range(n)]
    pose = [f"{rng.uniform(-9, 9):.3f}" for _ in range(3)]
    said = n + rng.choice([0, 0, -1, 1, 2])
    tokens = ["FLASER", str(said), *ranges, *pose, *pose, "1.0", "host", "1.0"]
    if rng.random() < 0.3:
        tokens[rng.randrange(1, len(tokens))] = rng.choice(NUMBERS)
    path = folder / "run.log"
    path.write_text(" ".join(tokens) + "\n")
    (frame,) = read_carmen(path)
    if said == n and tokens[2 + n : 5 + n] == pose and frame.pose != tuple(map(float, pose)):
        raise SilentError(f"pose {frame.pose} read for {pose}")
    if said != n and tokens[1] == str(said) and "host" in tokens:  # else it may be consistent
        raise SilentError(f"FLASER {said} with {n} ranges read")


def _bag_case(rng: random.Random, folder: Path, bag: bytes) -> None:
    data = bytearray(bag[: rng.randrange(len(bag))] if rng.random() < 0.5 else bag)
    for _ in range(rng.randrange(6)):
        data[rng.randrange(len(data))] = rng.randrange(256)
    path = folder / "bad.bag"
    path.write_bytes(bytes(data))
    read_rosbag(path)


def _output_case(rng: random.Random, folder: Path) -> None:
    mine = folder / "mine.txt"
    mine.write_text("mine")
    target = rng.choice([mine, mine / "x.txt", folder, folder / "new" / "x.txt"])
    try:
        write_text(target, "theirs")
    finally:
        if mine.read_text() != "mine":
            raise LostFileError(str(mine))


def _bag_bytes(folder: Path) -> bytes:
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    from tests.maps.test_rosbag import _write

    path = folder / "good.bag"
    with Writer(path) as writer:
        _write(writer, get_typestore(Stores.ROS1_NOETIC), True)
    return path.read_bytes()


def _alarm(*_: object) -> None:
    raise TimeoutError


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=3000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--hang", type=int, default=10, help="seconds a case may take")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    counts: Counter[str] = Counter()
    examples: dict[str, str] = {}
    signal.signal(signal.SIGALRM, _alarm)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        bag = _bag_bytes(Path(tmp))
        kinds = {
            "yaml": _yaml_case,
            "image": _image_case,
            "log": _log_case,
            "bag": lambda r, f: _bag_case(r, f, bag),
            "output": _output_case,
        }
        for case in range(args.cases):
            kind = rng.choice(sorted(kinds))
            folder = Path(tmp) / f"case{case}"
            folder.mkdir()
            signal.alarm(args.hang)
            try:
                kinds[kind](rng, folder)
                outcome = "read"
            except TopomapError as err:
                outcome = "typed error" if "\n" not in str(err) else "multi-line message"
            except SilentError as err:
                outcome, examples["silent"] = "silent wrong answer", f"{kind}: {err}"
            except LostFileError as err:
                outcome, examples["lost"] = "file lost", f"{kind}: {err}"
            except TimeoutError:
                outcome, examples["hang"] = "hang", kind
            except Exception as err:
                outcome, examples["crash"] = "crash", f"{kind}: {type(err).__name__}: {err}"
            finally:
                signal.alarm(0)
            counts[outcome] += 1
    print(f"{args.cases} cases in {time.perf_counter() - start:.1f} s")
    for outcome in ("read", "typed error", "multi-line message", "crash", "hang"):
        print(f"{outcome:>20}: {counts[outcome]}")
    for outcome in ("silent wrong answer", "file lost"):
        print(f"{outcome:>20}: {counts[outcome]}")
    for what, example in examples.items():
        print(f"e.g. {what}: {example[:300]}")
    bad = ("multi-line message", "crash", "hang", "silent wrong answer", "file lost")
    return 1 if any(counts[b] for b in bad) else 0


if __name__ == "__main__":
    sys.exit(main())
