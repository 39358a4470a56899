"""Cohort batches on Dask: :func:`run` (``vesselgp batch``).

A manifest (CSV) lists the inputs, one row each; its columns say what a row computes:

* ``mesh``: the vessel's fit (a tree when it has more than two ends): number of
  ends and paths, and of its main path (for a single vessel the path between its
  two ends; for a tree the path from the root, the widest end, to the tip farthest
  along the centre lines) the centre-line length, mean (length-weighted), min and
  max radius, tortuosity (path length over the distance between its ends) and
  statistics of its curvature and Frenet torsion; ``total_branch_length`` is the
  sum of the tree's branches (a single vessel's length). Every path of a tree is
  in the row's JSON (``detail.paths``);
* ``rest`` and ``deformed``: :func:`vesselgp.measure_torsion` (total twist, energy
  of Eq. 8, max ``|alpha'|``);
* ``scan_a`` and ``scan_b``: :func:`vesselgp.twist_between` (total twist, landmarks,
  segment twists).

Optional columns: ``ends`` (``"0 1"``; for a ``scan_a,scan_b`` row, scan A's main-vessel ends) and
``units`` (``mm``, ``cm``, ``m``, ``um``).
Relative paths are relative to the manifest's folder. Any other columns (``patient_id``, ``age``,
``side``, ...) are the cohort's own: every column of the manifest is carried unchanged (its text,
in manifest order) into the results, first, before the results' own columns (:data:`RESULT_COLUMNS`,
which a manifest column may therefore not be named: it is refused, to be renamed).

The rows run in this process, or as tasks on ``dask.distributed``: on a
``LocalCluster`` of worker processes, or on any cluster a ``Client`` connects to.
By default the rows run here, one after another, while the rows left would take
less time than a local cluster saves on them (its start-up costs about
``tolerances.BATCH_DASK_STARTUP_S``); once they would take longer, the rest go to a
cluster of one worker per core (:func:`dask_pays`, judged from the rows' own times).
A row that fails (a :class:`vesselgp.VesselError`, any other exception, a worker that
dies, or a task running longer than ``timeout``) is recorded in its row and the
batch goes on. Results are written atomically: ``OUT/results.csv`` (one row per
input, in manifest order; ``results.parquet`` too when pyarrow is installed) and
one JSON per row under ``OUT/rows/``, named by the row's key: the SHA-256 of
the input files' contents plus the kind, the options and vesselgp's version. A
re-run skips every row whose key already has a result, so an interrupted batch
resumes (``retry_errors`` runs the failed rows again); the manifest's own columns
are not part of the key (a corrected ``age`` is no reason to fit again): a re-run
takes them from the manifest given, and rewrites a row's JSON when they changed.
Rows with the same inputs and options share one result and one JSON, which holds
the first such row's columns (``results.csv`` holds each row's own).
"""
from __future__ import annotations

import csv
import hashlib
import importlib.util
import io
import json
import logging
import math
import os
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import tolerances as tol
from ._version import __version__
from .errors import OptionError, VesselError
from .io import atomic_write, to_json, write_json

log = logging.getLogger(__name__)

__all__ = ["run", "BatchReport", "read_manifest", "run_row", "dask_pays", "KINDS", "METRICS", "RESULT_COLUMNS"]

#: Manifest columns of each kind of row.
KINDS = {"mesh": ("mesh",), "torsion": ("rest", "deformed"), "twist": ("scan_a", "scan_b")}
#: Columns of results.csv after the manifest's own: every row has them.
BASE_COLUMNS = ("row", "kind", "inputs", "key", "status", "error_type", "error", "time_s")
#: Result columns of each kind of row (the row's ``metrics``), after :data:`BASE_COLUMNS`.
METRICS = {
    "mesh": ("n_vertices", "n_ends", "n_paths", "main_path_ends", "length", "mean_radius", "min_radius", "max_radius",
             "total_branch_length", "tortuosity", "curvature_mean", "curvature_max", "frenet_torsion_abs_mean",
             "frenet_torsion_abs_max"),
    "torsion": ("n_vertices", "total_twist_deg", "energy", "max_abs_dalpha_deg", "length",
                "twist_per_length_deg_per_cm", "smoothing_residual_deg"),
    "twist": ("n_landmarks", "total_twist_deg", "length", "mean_twist_per_length_deg_per_cm", "n_unmatched"),
}
#: Every column vesselgp adds to results.csv: a manifest column may not have one of these names.
RESULT_COLUMNS = tuple(dict.fromkeys(BASE_COLUMNS + sum(METRICS.values(), ())))


@dataclass(frozen=True)
class BatchReport:
    """What :func:`run` did.

    Attributes
    ----------
    rows : list of dict
        One per manifest row, in order: the columns of ``results.csv``.
    computed, skipped, failed : int
        Rows computed in this run, rows whose result was already in ``out``,
        rows whose status is ``error``.
    files : list of str
        Files written.
    time_s : float
    runner : {"serial", "dask", "serial, then dask", "none"}
        What computed the rows: this process, Dask, this process until Dask paid
        (:func:`dask_pays`), or nothing (every row was done before).
    serial_rows, dask_rows : int
        Rows computed in this process and on Dask.
    out : str
        The output folder.
    notes : tuple of str
        What was not written and why (``results.parquet`` without pyarrow).
    """

    rows: list
    computed: int
    skipped: int
    failed: int
    files: list
    time_s: float
    runner: str = "serial"
    serial_rows: int = 0
    dask_rows: int = 0
    out: str = ""
    notes: tuple = ()

    @property
    def failed_kinds(self):
        """dict: error type -> number of failed rows, most frequent first."""
        kinds = Counter(r["error_type"] or "error" for r in self.rows if r["status"] != "ok")
        return dict(kinds.most_common())

    def failure_summary(self):
        """One line on the failed rows (how many, which error kinds, where they are), or None when none failed.

        Examples
        --------
        >>> rows = [{"status": "ok", "error_type": None}] + 2 * [{"status": "error", "error_type": "ReadError"}]
        >>> print(BatchReport(rows, 3, 0, 2, [], 0.1, out="res").failure_summary())
        2 of 3 rows failed (ReadError 2); each row's error is in res/results.csv (status, error_type, error) and res/rows/<key>.json
        """
        if not self.failed:
            return None
        kinds = ", ".join(f"{k} {n}" for k, n in self.failed_kinds.items())
        where = os.path.join(self.out, "")
        return (f"{self.failed} of {len(self.rows)} rows failed ({kinds}); each row's error is in "
                f"{where}results.csv (status, error_type, error) and {where}rows/<key>.json")


def read_manifest(path):
    """The manifest's rows: dicts with ``row``, ``kind``, ``inputs`` (absolute paths), ``ends``, ``units`` and
    ``manifest`` (every column of the row, its text unchanged, in manifest order).

    A row whose kind cannot be told, or that holds more values than the header has columns, gets
    ``kind = None`` and an ``error`` (it is recorded as failed, not refused).

    Raises
    ------
    VesselError
        The file cannot be read or is not a text CSV, it has none of the columns of :data:`KINDS`,
        a column name twice, or a column named like a result column (:data:`RESULT_COLUMNS`).
    """
    return _read_manifest(path)[1]


def _read_manifest(path):
    """The manifest's column names (in order) and its rows (:func:`read_manifest`)."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise VesselError(f"cannot read manifest {path} ({exc.strerror})") from None
    what = f"manifest {path} is not a CSV text file"
    try:
        text = raw.decode("utf-8-sig")  # a spreadsheet's byte-order mark is not part of the first column's name
    except UnicodeDecodeError as exc:
        raise VesselError(f"{what} (byte {exc.object[exc.start]:#04x} at offset {exc.start} is not UTF-8 text); "
                          "give a CSV with a 'mesh' column, or 'rest' and 'deformed', or 'scan_a' and "
                          "'scan_b'") from None
    nul = text.find("\x00")
    if nul >= 0:
        raise VesselError(f"{what} (it holds a NUL byte at character {nul}); give a CSV with a 'mesh' column, or "
                          "'rest' and 'deformed', or 'scan_a' and 'scan_b'")
    try:
        lines = [r for r in csv.reader(io.StringIO(text)) if r]  # blank lines are skipped, as csv.DictReader does
    except csv.Error as exc:
        raise VesselError(f"{what} ({exc}); check its quoting") from None
    header = lines[0] if lines else []
    cols = set(header)
    if not any(set(c) <= cols for c in KINDS.values()):
        raise VesselError(f"manifest {path} needs a 'mesh' column, or 'rest' and 'deformed', or 'scan_a' and "
                          f"'scan_b'; it has {sorted(cols)}")
    twice = sorted({c for c in header if header.count(c) > 1})
    if twice:
        raise VesselError(f"manifest {path} names the column{'s' * (len(twice) > 1)} {', '.join(map(repr, twice))} "
                          "more than once; give each column its own name")
    clash = [c for c in header if c in RESULT_COLUMNS]
    if clash:
        raise VesselError(f"manifest {path} has column{'s' * (len(clash) > 1)} {', '.join(map(repr, clash))}, also "
                          f"the name{'s' * (len(clash) > 1)} of results the batch writes; rename "
                          f"{'them' if len(clash) > 1 else 'it'} (e.g. '{clash[0]}_manifest') to keep both")
    rows = []
    for i, values in enumerate(lines[1:]):
        manifest = dict(zip(header, values + [""] * (len(header) - len(values))))
        r = {k: v.strip() for k, v in manifest.items()}
        kinds = [k for k, c in KINDS.items() if all(r.get(x) for x in c)]
        row = {"row": i, "kind": kinds[0] if len(kinds) == 1 else None, "ends": r.get("ends") or None,
               "units": r.get("units") or None, "inputs": [], "error": None, "manifest": manifest}
        if len(values) > len(header):
            row["kind"] = None
            row["error"] = (f"row {i} holds {len(values)} values but the header names {len(header)} columns; name "
                            "every column in the header (a value without a column would be lost)")
        elif len(kinds) != 1:
            row["error"] = (f"row {i} fills {' and '.join(kinds)}: give one kind per row" if kinds else
                            f"row {i} names no input (mesh, rest/deformed or scan_a/scan_b)")
        else:
            row["inputs"] = [str((path.parent / r[c]).resolve()) for c in KINDS[kinds[0]]]
        rows.append(row)
    return header, rows


def _file_hash(p):
    with open(p, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def row_key(row):
    """The row's key: SHA-256 of its input files' contents, its kind, options and vesselgp's version.

    A missing file hashes as its name (the row then fails, and is retried once the file exists).
    """
    # a row that names no valid input is keyed by its place and message (no two collide)
    parts = [row["kind"] or f"invalid {row['row']}: {row['error']}", row["ends"] or "", row["units"] or "",
             __version__]
    for p in row["inputs"]:
        parts.append(_file_hash(p) if Path(p).is_file() else f"missing:{p}")
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:24]


def _ends(text):
    if text is None:
        return None
    try:
        i, j = (int(x) for x in text.replace(",", " ").split())
    except ValueError:
        raise VesselError(f"ends must be two end indices like '0 1', got {text!r}") from None
    return i, j


def _stats(x, name):
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if not len(x):
        return {f"{name}_mean": None, f"{name}_max": None}
    return {f"{name}_mean": float(np.mean(x)), f"{name}_max": float(np.max(x))}


def _path_metrics(gc):
    """Length, radii, tortuosity, curvature and Frenet torsion statistics of one path."""
    from .curves import frenet

    fr = frenet(gc.centers, length_scale=gc.mean_radius, smooth=True)
    chord = float(np.linalg.norm(gc.centers[-1] - gc.centers[0]))
    return {"ends": list(gc.ends), "length": gc.length, "mean_radius": gc.mean_radius,
            "min_radius": float(np.min(gc.radii)), "max_radius": float(np.max(gc.radii)),
            "tortuosity": gc.length / chord if chord > 0 else None,
            **_stats(fr.curvature, "curvature"),
            **_stats(np.abs(np.where(fr.defined, fr.torsion, np.nan)), "frenet_torsion_abs")}


def _mesh_job(path, ends, units):
    from .fit import fit_generalized_cylinder
    from .mesh import vessel_ends
    from .commands.output import read_mesh_in
    from .tree import fit_vessel_tree

    V, F, _ = read_mesh_in(path, units)
    all_ends = vessel_ends(V, F)
    if len(all_ends) > 2 and ends is None:
        tree = fit_vessel_tree(V, F, ends=all_ends)
        paths = [_path_metrics(p) for p in tree.paths]  # each from the root, the widest end
        main = int(np.argmax([p["length"] for p in paths]))  # to the tip farthest along the centre lines
        total = float(sum(b.length for b in tree.branches))
    else:
        gc = fit_generalized_cylinder(V, F, ends=ends, mesh_ends=all_ends)
        paths, main, total = [_path_metrics(gc)], 0, gc.length
    m = paths[main]
    metrics = {"n_vertices": len(V), "n_ends": len(all_ends), "n_paths": len(paths),
               "main_path_ends": " ".join(map(str, m["ends"])), "total_branch_length": total,
               **{k: m[k] for k in METRICS["mesh"] if k in m}}
    return {k: metrics[k] for k in METRICS["mesh"]}, {"paths": paths, "main_path": main}


def _torsion_job(rest, deformed, ends, units):
    from .commands.output import read_mesh_in
    from .torsion import measure_torsion

    V0, F0, _ = read_mesh_in(rest, units)
    V1, F1, _ = read_mesh_in(deformed, units)
    if V0.shape != V1.shape or not np.array_equal(F0, F1):
        raise VesselError("rest and deformed meshes must share vertices and faces")
    prof = measure_torsion(V0, V1, F0, ends=ends)
    m = {"n_vertices": len(V0), "total_twist_deg": math.degrees(prof.total_twist), "energy": prof.energy,
         "max_abs_dalpha_deg": float(np.degrees(np.max(np.abs(prof.dalpha)))), "length": prof.length,
         "twist_per_length_deg_per_cm": math.degrees(prof.twist_per_length) * 10.0,
         "smoothing_residual_deg": math.degrees(prof.smoothing_residual)}  # a worker's WARNING is not the user's
    return m, {"s": prof.s, "alpha_deg": np.degrees(prof.alpha)}


def _twist_job(a, b, ends, units):
    from .commands.output import read_mesh_in
    from .commands.twist import twist_to_dict
    from .twist import twist_between

    Va, Fa, _ = read_mesh_in(a, units)
    Vb, Fb, _ = read_mesh_in(b, units)
    r = twist_between(Va, Fa, Vb, Fb, ends_a=ends)
    d = twist_to_dict(r)
    m = {"n_landmarks": d["n_landmarks"], "total_twist_deg": d["total_twist_deg"], "length": r.length_a,
         "mean_twist_per_length_deg_per_cm": float(np.degrees(r.total_twist) / (r.s_a[-1] - r.s_a[0]) * 10.0),
         "n_unmatched": len(r.unmatched_a) + len(r.unmatched_b)}
    return m, d


_JOBS = {"mesh": _mesh_job, "torsion": _torsion_job, "twist": _twist_job}


def run_row(row):
    """Compute one manifest row; never raises. Returns its record (the row's JSON).

    Runs on a Dask worker (or in-process). Every exception, a
    :class:`vesselgp.VesselError` or a crash, becomes ``status = "error"`` with
    its type and one-line message.
    """
    t0 = time.perf_counter()
    rec = _record(row)
    try:
        if row["error"]:
            raise VesselError(row["error"])
        metrics, detail = _JOBS[row["kind"]](*row["inputs"], _ends(row["ends"]), row["units"])
        rec.update(status="ok", error_type="", error="", metrics=metrics, detail=detail)
    except Exception as exc:  # noqa: BLE001 - a failed row is recorded, never raised (module notes)
        rec.update(status="error", error_type=type(exc).__name__, error=" ".join(str(exc).split()) or repr(exc),
                   metrics={}, detail={})
    rec["time_s"] = time.perf_counter() - t0
    return to_json(rec)


def _record(row):
    """What every row's JSON starts with: the manifest's columns, the row and how it was computed."""
    return {"manifest": row.get("manifest", {}), "row": row["row"], "kind": row["kind"], "inputs": row["inputs"],
            "key": row["key"], "ends": row["ends"], "units": row["units"], "version": __version__}


def _failure(row, exc_type, message):
    """The record of a row that failed outside :func:`run_row` (a dead worker, a time-out)."""
    return to_json({**_record(row), "status": "error", "error_type": exc_type, "error": message, "metrics": {},
                    "detail": {}, "time_s": None})


def _progress_bar(progress, total):
    if progress is True:
        from tqdm import tqdm

        return tqdm(total=total, desc="vesselgp batch", unit="row")
    return progress(total=total) if callable(progress) else None


def _serial(todo, save, bar):
    for row in todo:
        save(row, run_row(row))
        if bar is not None:
            bar.update(1)


def _input_bytes(row):
    """Total size of a row's input files (a missing one counts 0: its row fails on the worker)."""
    return sum(Path(p).stat().st_size for p in row["inputs"] if Path(p).is_file())


_FINAL = ("finished", "error", "cancelled")  # a Dask future's end states ("lost" is not one)


def _on_dask(client, todo, save, bar, timeout):
    """Submit every row, collect them as they finish; a task past ``timeout`` s of running is failed."""
    # largest inputs first (Dask runs higher priorities first): the last rows to finish are then short
    # ones, and the workers idle less at the end of the batch
    futures = {client.submit(run_row, row, key=f"vesselgp-row-{row['key']}", pure=False, priority=_input_bytes(row)):
               row for row in todo}
    pending, started, last_look = set(futures), {}, -math.inf
    while pending:
        # a future's status is read once: a finished task whose worker then dies is "lost" (its result
        # went with the worker) and Dask computes it again, so it stays pending, not a failed row
        finished = [(f, status) for f in pending if (status := f.status) in _FINAL]
        for f, status in finished:
            save(futures[f], _outcome(futures[f], f, status))
            pending.discard(f)
            if bar is not None:
                bar.update(1)
        if timeout is not None and pending and time.monotonic() - last_look >= tol.BATCH_TIMEOUT_POLL_S:
            now = last_look = time.monotonic()
            for keys in client.run(_executing).values():  # running now, not merely queued on a worker
                for k in keys:
                    started.setdefault(str(k), now)
            for f in [f for f in pending if now - started.get(str(f.key), now) > timeout]:
                f.cancel()
                save(futures[f], _failure(futures[f], "TimeoutError",
                                          f"still running after {timeout:g} s on a worker; cancelled"))
                pending.discard(f)
                if bar is not None:
                    bar.update(1)
        if not finished:
            time.sleep(tol.BATCH_POLL_S)


def _outcome(row, future, status):
    """A row's record from its finished future (``status`` one of ``_FINAL``), a failure record if it failed.

    The task raised outside ``run_row``, its worker died (``KilledWorker``) or it was cancelled: each is
    a failed row (``run_row`` itself returns a ``VesselError`` as a record). A result lost after the
    status was read is computed again by Dask, and ``result()`` waits for it; if that run fails, so
    does the row.
    """
    if status == "cancelled":
        return _failure(row, "cancelled", "task cancelled")
    try:
        return future.result()
    except Exception as exc:  # the worker's exception, re-raised here by Dask: the row failed
        return _failure(row, type(exc).__name__, " ".join(str(exc).split()))


def _executing(dask_worker):
    """Keys of the tasks a worker is running (``client.run`` passes the worker)."""
    return [str(ts.key) for ts in dask_worker.state.executing]


def _cluster(workers):
    import dask

    Client = _dask_client()
    from distributed import LocalCluster

    # Dask's worker defaults cost numerical code dearly. Its MALLOC_TRIM_THRESHOLD_ (64 KiB) switches
    # off glibc's dynamic mmap threshold, so every numpy array above 128 KiB is mmapped and unmapped
    # again and page-faults on each use (a 60k tree fit: 10x the page faults, 1.6x the time). The
    # workers get large trim and mmap thresholds instead. A nanny takes these variables from this
    # process's environment before its configuration (and writes them into it), so they are set
    # here while the workers start and put back afterwards. The statistical profiler (every 10 ms)
    # is off; BLAS keeps one thread per worker (Dask's default, also set below).
    malloc = {k: str(tol.BATCH_MALLOC_THRESHOLD) for k in ("MALLOC_TRIM_THRESHOLD_", "MALLOC_MMAP_THRESHOLD_")}
    environ = {**dask.config.get("distributed.nanny.pre-spawn-environ", {}), **malloc}
    saved = {k: os.environ.get(k) for k in malloc}
    os.environ.update(malloc)
    try:
        # one task on a worker at a time: a row that kills its worker process then takes no other
        # row with it (Dask counts every task on a dead worker against its allowed failures)
        with dask.config.set({"distributed.nanny.pre-spawn-environ": environ,
                              "distributed.worker.profile.enabled": False,
                              "distributed.scheduler.worker-saturation": 1.0}):
            return _local_cluster(Client, LocalCluster, workers)
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _local_cluster(Client, LocalCluster, workers):
    """A LocalCluster and its client; the cluster is closed again when the client cannot connect."""
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=logging.WARNING,
                           env={k: "1" for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")})
    try:
        return Client(cluster), cluster
    except BaseException:
        cluster.close()
        raise


def _dask_client():
    try:
        from distributed import Client
    except ImportError:
        raise OptionError("vesselgp batch runs on dask.distributed; install it with pip install vesselgp[batch] "
                          "(or run serially with workers=0)") from None
    return Client


def run(manifest, out, client=None, *, workers=None, scheduler=None, timeout=None, retry_errors=False,
        progress=None):
    """Run a manifest of vessels and write ``results.csv``, ``results.parquet`` and one JSON per row.

    Parameters
    ----------
    manifest : str or os.PathLike
        The CSV (see the module notes).
    out : str or os.PathLike
        Output folder (created when the first result is written; an existing one is resumed).
    client : distributed.Client, optional
        Run on this client's cluster.
    workers : int, optional
        Without ``client`` and ``scheduler``: worker processes of the LocalCluster started (and
        closed) here, one thread each; 0 runs the rows serially in this process, without Dask.
        Default: the rows run in this process while the rows left would not pay for a
        LocalCluster of one worker per core (:func:`dask_pays`), the rest on one (with a
        ``timeout``: on one from the start, as a row in this process cannot be stopped).
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``) to submit to.
    timeout : float, optional
        Seconds a row may run on a worker (counted from when it starts running, not while it
        waits in a queue) before it is recorded as a ``TimeoutError`` and cancelled (Dask cannot
        interrupt a running function: the worker finishes it and moves on). Not used when
        ``workers=0``.
    retry_errors : bool
        Run rows that failed before again (default: a re-run skips every row with a result).
    progress : None, bool or callable
        A tqdm progress bar (True) or a tqdm-like callable taking ``total``.

    Returns
    -------
    BatchReport

    Raises
    ------
    VesselError
        An unreadable manifest (see :func:`read_manifest`), or an output folder that would
        overwrite an input.
    """
    t0 = time.perf_counter()
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, (int, np.integer))
                                or workers < 0):
        raise OptionError(f"workers must be a whole number >= 0 (0: serial, without Dask), got {workers!r}")
    if timeout is not None and not float(timeout) > 0:
        raise OptionError(f"timeout must be a positive number of seconds, got {timeout!r}")
    manifest = Path(manifest).resolve()
    columns, rows = _read_manifest(manifest)
    out = Path(out)
    rows_dir = out / "rows"
    outputs = {(out / n).resolve() for n in ("results.csv", "results.parquet")}
    if manifest in outputs or any(Path(p) in outputs or Path(p).resolve().parent == rows_dir.resolve()
                                  for r in rows for p in r["inputs"]):
        raise VesselError(f"output folder {out} would overwrite an input; choose another -o")
    records, todo, first = {}, [], {}
    for row in rows:
        row["key"] = row_key(row)
        if row["key"] in first:  # the same inputs and options again: one result serves both rows
            continue
        first[row["key"]] = row
        f = rows_dir / f"{row['key']}.json"
        if f.is_file():
            rec = json.loads(f.read_text())
            if rec.get("status") == "ok" or not retry_errors:
                records[row["key"]] = rec
                continue
        todo.append(row)
    files = []

    def save(row, rec):
        records[row["key"]] = rec
        rows_dir.mkdir(parents=True, exist_ok=True)  # here, not before: a run that computes nothing makes no folder
        write_json(rows_dir / f"{row['key']}.json", rec)
        files.append(str(rows_dir / f"{row['key']}.json"))

    bar = _progress_bar(progress, len(todo)) if todo else None
    created = []  # what this call opened, closed again whatever happens
    on_dask, runner = [], "none"
    try:
        if not todo:
            pass
        elif client is not None or scheduler or workers or (workers is None and timeout is not None):
            on_dask, runner = todo, "dask"
        elif workers == 0:
            _serial(todo, save, bar)
            runner = "serial"
        else:
            on_dask = _serial_while_dask_does_not_pay(todo, save, bar)
            runner = "serial, then dask" if on_dask else "serial"
        if on_dask:
            if client is None and scheduler:
                client = _dask_client()(scheduler)
                created.append(client)
            elif client is None:
                client, cluster = _cluster(workers or _cores())
                created += [client, cluster]
            _on_dask(client, on_dask, save, bar, timeout)
    finally:
        for x in created:
            x.close()
        if bar is not None:
            bar.close()
    for row in first.values():  # a row done before: its JSON describes it in this manifest
        rec = records[row["key"]]
        now = {"manifest": row["manifest"], "row": row["row"], "inputs": row["inputs"]}
        if any(rec.get(k) != v for k, v in now.items()) or list(rec["manifest"]) != list(row["manifest"]):
            save(row, {**now, **{k: v for k, v in rec.items() if k not in now}})
    table = [_result_row(row, records[row["key"]]) for row in rows]
    out.mkdir(parents=True, exist_ok=True)
    written, notes = _write_results(out, columns, table)
    files += written
    failed = sum(r["status"] != "ok" for r in table)
    log.info("batch: %d rows, %d computed (%s), %d failed", len(rows), len(todo), runner, failed)
    return BatchReport(rows=table, computed=len(todo), skipped=len(rows) - len(todo), failed=failed, files=files,
                       time_s=time.perf_counter() - t0, runner=runner, serial_rows=len(todo) - len(on_dask),
                       dask_rows=len(on_dask), out=str(out), notes=notes)


def dask_pays(rows_left, row_s, cores):
    """Whether a local Dask cluster would finish the rows left sooner than this process.

    In this process the rows take ``rows_left * row_s`` seconds; on a LocalCluster of
    ``w = min(cores, rows_left)`` worker processes about ``BATCH_DASK_STARTUP_S`` (importing Dask,
    starting the cluster, the workers' imports, closing it) plus ``rows_left * (row_s + BATCH_DASK_ROW_S)``
    (each row's scheduling) divided by the cluster's speed-up ``BATCH_DASK_EFFICIENCY * w``: the
    constants of :mod:`vesselgp.tolerances`, measured by ``scripts/bench_batch.py --crossover``. On 2
    cores Dask pays above about 5.1 s of rows (13 rows of 0.4 s; 1 row of 7 s never: it cannot be split).

    Parameters
    ----------
    rows_left : int
        Rows still to compute.
    row_s : float
        Seconds a row takes in this process (the mean of the rows computed so far).
    cores : int
        Cores of this machine (the cluster's workers).

    Returns
    -------
    bool

    Examples
    --------
    >>> dask_pays(1, 100.0, 8), dask_pays(8, 0.01, 2), dask_pays(8, 60.0, 2), dask_pays(8, 60.0, 1)
    (False, False, True, False)
    """
    w = min(int(cores), int(rows_left))
    if w < 2:
        return False
    on_dask = tol.BATCH_DASK_STARTUP_S + rows_left * (row_s + tol.BATCH_DASK_ROW_S) / (tol.BATCH_DASK_EFFICIENCY * w)
    return on_dask < rows_left * row_s


def _serial_while_dask_does_not_pay(todo, save, bar):
    """Compute rows here, one after another, until the rest would pay for a local cluster; returns the rest."""
    cores, spent = _cores(), 0.0
    if cores > 1 and len(todo) > 1 and importlib.util.find_spec("distributed") is None:
        log.info("batch: dask.distributed is not installed: every row runs here (pip install vesselgp[batch])")
        cores = 1
    for i, row in enumerate(todo):
        if i and dask_pays(len(todo) - i, spent / i, cores):
            log.info("batch: %d rows computed here (%.2f s each); the %d left go to a local Dask cluster of %d "
                     "workers", i, spent / i, len(todo) - i, min(cores, len(todo) - i))
            return todo[i:]
        t = time.perf_counter()
        save(row, run_row(row))
        spent += time.perf_counter() - t
        if bar is not None:
            bar.update(1)
    log.info("batch: %d rows computed here, one after another (%.2f s each): a local Dask cluster (%d cores) "
             "would not have paid for its start-up (about %.1f s)", len(todo), spent / len(todo), cores,
             tol.BATCH_DASK_STARTUP_S)
    return []


def _cores():
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1))


def _result_row(row, rec):
    """One line of results.csv: the manifest's columns, the row's place in this manifest, its status and its
    metrics."""
    base = {"row": row["row"], "kind": row["kind"] or "", "inputs": ";".join(row["inputs"]), "key": row["key"],
            "status": rec["status"], "error_type": rec["error_type"], "error": rec["error"],
            "time_s": rec["time_s"]}
    return {**row["manifest"], **base, **rec.get("metrics", {})}


#: Said when results.parquet cannot be written.
NO_PARQUET = "results.parquet not written: it needs pyarrow (pip install 'vesselgp[batch]')"


def _write_results(out, columns, table):
    """results.csv (and results.parquet when pyarrow is installed), atomically: the manifest's ``columns``
    first. Returns the files written and what was not (:data:`NO_PARQUET`)."""
    cols = list(columns) + list(BASE_COLUMNS)
    for r in table:
        cols += [k for k in r if k not in cols]

    def csv_writer(fh):
        w = csv.DictWriter(fh, fieldnames=cols, extrasaction="ignore", lineterminator="\n")
        w.writeheader()
        for r in table:
            w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in cols})

    atomic_write(out / "results.csv", csv_writer)
    files = [str(out / "results.csv")]
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        log.info(NO_PARQUET)  # the report's notes carry it to the summary (stdout): stderr is for failures
        return files, (NO_PARQUET,)
    t = pa.Table.from_pylist([{k: r.get(k) for k in cols} for r in table])
    atomic_write(out / "results.parquet", lambda fh: pq.write_table(t, fh), binary=True)
    return files + [str(out / "results.parquet")], ()
