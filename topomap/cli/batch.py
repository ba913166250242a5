"""``topomap batch``: segment, label and export many maps, logs and bags on a Dask cluster.

Each input (a map_server YAML, a CARMEN log, a ROS bag) is one task on ``dask.distributed``:
a :class:`~distributed.LocalCluster` of worker processes by default, or an existing cluster
given by its scheduler address. A task writes its results into a hidden folder and renames it
into place when everything is written, so an output folder is always complete; its
``result.json`` marks the input done, and a re-run skips it. The driver rewrites ``index.csv``
and ``summary.json`` after every finished input, keeping the records of earlier runs.
"""

from __future__ import annotations

import csv
import io
import json
import logging
import re
import shutil
import sys
import time
import traceback
import uuid
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Protocol

from maps.errors import OutputExistsError
from maps.files import check_output_folder, write_text
from topomap.cli.inputs import Job, find_inputs
from topomap.errors import SchedulerError

log = logging.getLogger(__name__)

#: Columns of ``index.csv``.
COLUMNS = ["name", "source", "kind", "status", "regions", "keyframes", "seconds", "error"]


@dataclass(frozen=True)
class BatchOptions:
    """How each input is read (the options of ``topomap segment``); ``segmenter`` holds the
    options of :meth:`TopoMap.from_grid` / :meth:`TopoMap.from_keyframes` (criterion, k...)."""

    distance: float = 0.5
    resolution: float = 0.05
    segmenter: dict[str, Any] = field(default_factory=dict)
    scan_topic: str | None = None
    fixed_frame: str | None = None
    map_topic: str | None = None
    stamp: float | None = None


def _topomap(job: Job, options: BatchOptions) -> tuple[Any, bool, str]:
    """The segmented :class:`TopoMap` of one input, whether it came from scans, and how a
    bag's scans were placed."""
    from maps.carmen import read_carmen
    from maps.grid import OccupancyGrid
    from maps.rosbag import read_bag_scans, read_rosbag_map
    from maps.scan import select_keyframes
    from topomap.topomap import TopoMap

    segmenter = options.segmenter
    if job.kind == "map" or (job.kind == "bag" and options.map_topic is not None):
        if job.kind == "map":
            grid = OccupancyGrid.load(job.source)
        else:
            grid = read_rosbag_map(job.source, topic=options.map_topic, stamp=options.stamp)
        return TopoMap.from_grid(grid, **segmenter), False, ""
    placed = ""
    if job.kind == "bag":
        found = read_bag_scans(
            job.source, scan_topic=options.scan_topic, fixed_frame=options.fixed_frame
        )
        frames, placed = found.keyframes, found.describe()
    else:
        frames = read_carmen(job.source)
    keyframes = select_keyframes(frames, distance=options.distance)
    topo = TopoMap.from_keyframes(keyframes, resolution=options.resolution, **segmenter)
    return topo, True, placed


def process(job: Job, out: str, options: BatchOptions) -> dict[str, Any]:
    """Segment, label and export one input into ``out/<job.name>`` (runs on a worker): what
    :meth:`TopoMap.save` writes, the map (``map.yaml`` + ``map.pgm``), ``keyframes.csv`` for a
    log or bag, and ``result.json`` (the input's record).

    Everything is written into a hidden folder first and moved into place at the end (an
    earlier result of the same input, kept until then, is replaced only now). Any error is
    returned as a ``failed`` record with its traceback, never raised, so one bad input cannot
    stop the batch.
    """
    start = time.perf_counter()
    record: dict[str, Any] = {"name": job.name, "source": job.source, "kind": job.kind}
    work = Path(out) / f".{job.name}.{uuid.uuid4().hex[:8]}.partial"
    try:
        topo, from_scans, placed = _topomap(job, options)
        work.mkdir(parents=True)
        topo.save(work)
        if not (work / "map.yaml").exists():  # the map the regions are aligned with
            topo.grid.save(work / "map.yaml")
        if from_scans:
            topo.save_keyframes(work / "keyframes.csv")
        record.update(
            status="ok",
            regions=topo.graph.number_of_nodes(),
            keyframes=len(topo.keyframes),
            placed=placed,
            names={int(r): n for r, n in sorted(topo.graph.nodes(data="name"))},
            files=sorted(p.name for p in work.iterdir()),
            seconds=round(time.perf_counter() - start, 3),
            error="",
        )
        write_text(work / "result.json", json.dumps(record, indent=1))
        final = Path(out) / job.name
        old = final.with_name(f".{job.name}.{uuid.uuid4().hex[:8]}.old")
        if final.exists():
            final.rename(old)
        work.rename(final)
        shutil.rmtree(old, ignore_errors=True)
    except Exception as err:  # isolated per input; the traceback is kept in the record
        shutil.rmtree(work, ignore_errors=True)
        record.update(
            status="failed",
            regions="",
            keyframes="",
            seconds=round(time.perf_counter() - start, 3),
            error=f"{type(err).__name__}: {err}",
            traceback=traceback.format_exc(),
        )
    return record


def finished(out: Path, name: str) -> dict[str, Any] | None:
    """The record of an input already done in ``out`` (its folder's ``result.json``)."""
    try:
        record = json.loads((out / name / "result.json").read_text())
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) and record.get("status") == "ok" else None


def _ours(out: Path) -> None:
    """Refuse an ``index.csv`` or ``summary.json`` in ``out`` that ``topomap batch`` did not
    write (it would be replaced)."""
    index, summary = out / "index.csv", out / "summary.json"
    if index.is_file():
        with index.open(encoding="utf-8", errors="replace") as stream:
            if stream.readline().rstrip("\r\n") != ",".join(COLUMNS):
                raise OutputExistsError(index, "--force (it is not a topomap batch index)")
    if summary.is_file():
        try:
            content = json.loads(summary.read_text())
            ours = isinstance(content, dict) and {"run", "counts", "inputs"} <= set(content)
        except (ValueError, UnicodeDecodeError, RecursionError):
            ours = False
        if not ours:
            raise OutputExistsError(summary, "--force (it is not a topomap batch summary)")


@dataclass
class Index:
    """``index.csv`` and ``summary.json`` of an output folder: one record per input ever run
    there, this run's replacing earlier ones of the same name."""

    out: Path
    records: dict[str, dict[str, Any]] = field(default_factory=dict)
    run: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def read(cls, out: Path) -> Index:
        try:
            summary = json.loads((out / "summary.json").read_text())
            records = {r["name"]: r for r in summary["inputs"]}
        except (OSError, ValueError, KeyError, TypeError):
            records = {}
        return cls(out, records)

    def add(self, record: dict[str, Any]) -> None:
        self.records[record["name"]] = record
        self.write()

    def counts(self) -> dict[str, int]:
        statuses = [r["status"] for r in self.records.values()]
        return {s: statuses.count(s) for s in ("ok", "skipped", "failed")}

    def write(self) -> None:
        rows = sorted(self.records.values(), key=lambda r: r["name"])
        stream = io.StringIO()
        writer = csv.DictWriter(stream, COLUMNS, extrasaction="ignore", lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        write_text(self.out / "index.csv", stream.getvalue(), overwrite=True)
        summary = {"run": self.run, "counts": self.counts(), "inputs": rows}
        write_text(self.out / "summary.json", json.dumps(summary, indent=1), overwrite=True)


class Bar(Protocol):
    """A progress bar (tqdm's interface): the batch driver's, not the commands' stages
    (:class:`topomap.cli.progress.Progress`)."""

    def update(self, n: int = 1) -> object: ...

    def close(self) -> object: ...


def warm_up() -> None:
    """Import the pipeline in a worker (seconds of imports its first input would pay)."""
    import topomap.topomap  # noqa: F401


@contextmanager
def dask_client(workers: int = 2, scheduler: str | None = None) -> Iterator[Any]:
    """A ``distributed.Client``: on the cluster at ``scheduler``, or on a new local cluster of
    ``workers`` single-threaded processes (closed on exit). Every worker has imported the
    pipeline when it is returned."""
    from distributed import Client, LocalCluster

    if scheduler is not None:
        scheduler = scheduler_address(scheduler)
    # the scheduler and nannies log every start and stop at INFO in this process
    logging.getLogger("distributed").setLevel(logging.WARNING)
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=CONNECT_SECONDS)
        except Exception as err:
            reason = " ".join(str(err).split())[:200]
            raise SchedulerError(
                f"cannot reach the Dask scheduler at {scheduler}: {reason}"
            ) from None
        with client:
            client.run(warm_up)
            yield client
        return
    try:
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # any free port: several clusters may run at once
            silence_logs=logging.ERROR,
        )
    except (OSError, RuntimeError) as err:  # workers that cannot start (no /dev/shm, limits)
        reason = " ".join(str(err).split())[:200]
        raise SchedulerError(
            f"cannot start a local Dask cluster of {workers} worker processes: {reason}"
        ) from None
    with cluster, Client(cluster) as client:
        client.run(warm_up)
        yield client


#: Seconds to wait for a scheduler given by ``--scheduler``.
CONNECT_SECONDS = 10
_ADDRESS = re.compile(r"^(?:(tcp|tls|ws|wss|ucx)://)?(\[[0-9a-fA-F:]+\]|[\w.-]+):(\d{1,5})$")


def scheduler_address(text: str) -> str:
    """A Dask scheduler address ``[tcp://]host:port``, checked before anything connects.

    Examples
    --------
    >>> scheduler_address("tcp://127.0.0.1:8786")
    'tcp://127.0.0.1:8786'
    >>> scheduler_address("nonsense")
    Traceback (most recent call last):
    ...
    topomap.errors.SchedulerError: --scheduler 'nonsense' is not a Dask address like tcp://host:8786
    """
    found = _ADDRESS.match(text.strip())
    if found is None or not 0 < int(found.group(3)) < 65536:
        raise SchedulerError(f"--scheduler {text!r} is not a Dask address like tcp://host:8786")
    return text.strip() if found.group(1) else f"tcp://{text.strip()}"


def tqdm_bar(total: int) -> Bar:
    """A tqdm bar over ``total`` inputs on stderr."""
    from tqdm import tqdm

    return tqdm(total=total, desc="inputs", unit="input", file=sys.stderr, dynamic_ncols=True)


def check_batch(
    inputs: Sequence[str], out: str | Path, *, force: bool = False, scheduler: str | None = None
) -> list[Job]:
    """Everything :func:`run_batch` refuses, checked before a cluster starts: the inputs
    (:func:`find_inputs`), the output folder (not a file, its index not another tool's) and
    the scheduler's address."""
    jobs = find_inputs(inputs)
    folder = check_output_folder(out)
    if not force:
        _ours(folder)
    if scheduler is not None:
        scheduler_address(scheduler)
    return jobs


def run_batch(
    inputs: Sequence[str],
    out: str | Path,
    *,
    client: Any,
    force: bool = False,
    options: BatchOptions | None = None,
    progress: Callable[[int], Bar] | None = None,
) -> list[dict[str, Any]]:
    """Segment, label and export every input on a Dask ``client``, one folder each in ``out``.

    Parameters
    ----------
    inputs
        Map YAMLs, CARMEN logs, ROS bags, folders of them, globs.
    out
        The output folder: ``<name>/`` per input, ``index.csv``, ``summary.json``.
    client
        A ``distributed.Client`` (see :func:`dask_client`).
    force
        Redo inputs already done (else they are skipped and keep their results).
    options
        How inputs are read and segmented.
    progress
        Called with the number of inputs to run; returns a bar updated once per input.

    Returns
    -------
    list of dict
        One record per input in input order: ``name, source, kind, status`` (``ok``,
        ``skipped`` or ``failed``), ``regions``, ``keyframes``, ``seconds``, ``error``.

    Examples
    --------
    >>> with dask_client(workers=2) as client:  # doctest: +SKIP
    ...     records = run_batch(["maps/*.yaml"], "out/batch", client=client)
    """
    out = Path(out)
    jobs = check_batch(inputs, out, force=force)
    options = options or BatchOptions()
    out.mkdir(parents=True, exist_ok=True)
    index = Index.read(out)
    index.run = {"inputs": list(inputs), "options": asdict(options), "force": force}
    index.run["scheduler"] = str(client.scheduler.address)
    index.run["workers"] = len(client.scheduler_info().get("workers", {}))
    todo = []
    for job in jobs:
        done = None if force else finished(out, job.name)
        if done is not None:
            index.records[job.name] = {**done, "status": "skipped"}
        else:
            todo.append(job)
    index.write()
    log.info("%d inputs, %d done before, %d to run", len(jobs), len(jobs) - len(todo), len(todo))
    from distributed import as_completed

    bar = progress(len(todo)) if progress is not None else None
    start = time.perf_counter()
    futures = {
        client.submit(
            process, job, str(out), options, key=f"topomap-{job.name}-{uuid.uuid4().hex}"
        ): job
        for job in todo
    }
    try:
        for future in as_completed(futures):
            job = futures[future]
            try:
                record = future.result()
            except Exception as err:  # a worker lost, a task cancelled: that input only
                record = {
                    **asdict(job),
                    "status": "failed",
                    "regions": "",
                    "keyframes": "",
                    "seconds": "",
                    "error": f"{type(err).__name__}: {err}",
                }
            if record["status"] == "failed":
                log.warning("%s failed: %s", job.source, record["error"])
            index.add(record)
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
        for future in futures:
            future.cancel()
    index.run["seconds"] = round(time.perf_counter() - start, 3)
    index.write()
    return [index.records[job.name] for job in jobs]
