"""``micropit run``: a study's blocks with checkpoints, restart and clean stops (docs/hpc.md §3).

Per block: every group runs its items (:class:`~micropit_hpc.study.Study`), the records are
gathered, a checkpoint is written (every ``checkpoint_every`` blocks and after the last), and
the ranks agree whether to stop (signal, STOP file, wall-time budget:
:class:`~micropit_hpc.parallel.control.StopControl`). A stop writes the checkpoint of the block
just done and returns ``stopped``; the command then exits with
:data:`~micropit_hpc.parallel.control.EXIT_CHECKPOINTED` (85) for the job script to requeue.

Checkpoint layout (``OUT/checkpoints/ckpt_<block>.h5``, :mod:`micropit_hpc.io.checkpoint`):
per item, for each body ``bodyB/heights``, ``bodyB/wear``, ``bodyB/pit_depth`` (n_x, n_y,
metres), ``bodyB/pitted`` (uint8), ``bodyB/damage`` (N_z, n_x, n_y; each rank of a group writes
its own x rows), ``state`` (cycles, blocks, R_q0 of body 1 and 2) and ``records`` (blocks ×
:data:`RECORD_FIELDS`, NaN after the last block done). Attributes: the scene (JSON), the scene
file, the work items, the seed and how the random streams derive from it, the life settings.

A restart reads the newest complete checkpoint on any number of ranks and any
``ranks_per_item`` (the arrays are indexed by item, never by rank) and assigns the items
longest-first by their last block's time. It refuses a checkpoint of a different scene unless
``force``; the work items and the window must match in any case. N blocks straight equal k
blocks + restart + N − k blocks, bit for bit on the same layout (tests/test_restart*.py).
"""

from __future__ import annotations

import json
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from micropit_hpc.errors import collective
from micropit_hpc.io.checkpoint import (
    CheckpointError,
    Expected,
    FieldSpec,
    Piece,
    checkpoint_name,
    find_latest,
    read_attrs,
    read_checkpoint,
    write_checkpoint,
)
from micropit_hpc.io.hdf5 import h5py_module, scene_json
from micropit_hpc.parallel.control import StopControl
from micropit_hpc.parallel.petsc import stage
from micropit_hpc.parallel.share import from_root, raise_agreed
from micropit_hpc.plan import Plan
from micropit_hpc.scene import Scene
from micropit_hpc.state import (
    BODY_FIELDS,
    ITEM_STATE,
    RECORD_FIELDS,
    BlockRecord,
    item_state_row,
    record_from_row,
    record_row,
    restore_item_state,
)
from micropit_hpc.study import Study

__all__ = ["Checkpoints", "Handler", "RunOptions", "RunOutcome", "run_study"]

CHECKPOINT_DIR = "checkpoints"
#: The wall-time budget reserves this many times the longest block so far for the next one.
NEXT_BLOCK_MARGIN = 1.2

@dataclass(frozen=True)
class RunOptions:
    """How to run a study (the ``micropit run`` options)."""

    out: Path
    positions: tuple[int, ...] | None = None
    ranks_per_item: int = 1
    restart: bool = False
    force: bool = False
    max_wall_s: float | None = None
    stop_file: Path | None = None
    keep: int = 3
    checkpoint_every: int = 1
    balance: str = "dynamic"


@dataclass
class RunOutcome:
    """What a run did: ``status`` ``"done"`` or ``"stopped"`` (checkpointed, exit 85), the
    blocks done (all runs together), the block it started from, the records of every item
    (every rank), why it stopped, and the study."""

    status: str
    blocks_done: int
    start_block: int
    records: dict[int, list[BlockRecord]]
    reason: str | None
    study: Study
    run_id: str | None = None


def _field_specs(study: Study) -> list[FieldSpec]:
    """The checkpoint's fields: the item state row, the block records, and every stored
    array of each body (:data:`~micropit_hpc.state.BODY_FIELDS`)."""
    grid, z = study.plan.window.grid, study.plan.window.z
    specs = [FieldSpec("state", (len(ITEM_STATE),), "f8"),
             FieldSpec("records", (study.blocks, len(RECORD_FIELDS)), "f8")]
    for b in (1, 2):
        specs += [FieldSpec(f"body{b}/{f.name}", (z.size, *grid.shape) if f.layered
                            else grid.shape, f.dtype) for f in BODY_FIELDS]
    return specs


def _items_json(study: Study) -> str:
    return json.dumps([[i.id, i.position, i.k_lub, i.scale, i.patch] for i in study.items])


def surface_files(scene: Scene) -> dict[str, str]:
    """{path: SHA-256} of every measured-surface file the scene reads (kind = "file")."""
    import hashlib

    out = {}
    for b in (scene.body1, scene.body2):
        spec = b.surface
        if spec.kind == "file" and spec.file is not None:
            h = hashlib.sha256()
            try:
                with open(spec.file, "rb") as fh:
                    for chunk in iter(lambda fh=fh: fh.read(1 << 20), b""):
                        h.update(chunk)
            except OSError as e:
                raise collective(CheckpointError(
                    f"{scene.source}: cannot read the measured surface {spec.file}: "
                    f"{e.strerror or e}")) from None
            out[str(spec.file)] = h.hexdigest()
    return out


#: Attributes a usable checkpoint of a run must carry (besides write_checkpoint's own).
RUN_ATTRS = ("scene", "scene_file", "items", "seed", "blocks", "block_cycles", "life_cycles")
# (and, from checkpoint format 2 on, "run_id" and "surface_files")


def _expected(study: Study) -> Expected:
    """The layout a checkpoint of ``study`` must have before a restart may choose it."""

    def check(f, attrs):
        done = attrs.get("block")
        rec = f["records"]
        if rec.shape[-1] != len(RECORD_FIELDS) or not isinstance(done, int) \
                or not 1 <= done <= rec.shape[1]:
            raise CheckpointError(f"{f.filename}: records of shape {rec.shape} cannot hold "
                                  f"block {done!r} of {len(RECORD_FIELDS)} columns")
        for i in range(rec.shape[0]):
            tab = rec[i, :done]
            if not np.all(np.isfinite(tab)):
                raise CheckpointError(f"{f.filename}: records of item {i} hold non-finite "
                                      f"values within the {done} blocks done")
            state = f["state"][i]
            if int(state[1]) != done:
                raise CheckpointError(f"{f.filename}: item {i} is at block {int(state[1])}, "
                                      f"the checkpoint says block {done}")

    # the items and the number of blocks may differ (then _inspect says why it cannot resume)
    return Expected(fields=_field_specs(study), attrs=RUN_ATTRS, any_shape=("records",),
                    nan_ok=("records",), check=check)


def _attrs(study: Study, scene: Scene, run_id: str, surfaces: dict[str, str]) -> dict:
    return {"run_id": run_id, "surface_files": surfaces,
            "scene": scene_json(scene.document), "scene_file": str(scene.source),
            "items": _items_json(study), "seed": int(scene.window.seed),
            "rng": "numpy SeedSequence(seed, spawn_key=(body,) or (body, patch)); per-row "
                   "streams (surfaces/synthetic.py); no state advances during a run",
            "blocks": study.blocks, "block_cycles": float(scene.life.block),
            "life_cycles": float(scene.life.cycles)}


def _pieces(study: Study, records: dict[int, list[BlockRecord]]) -> list[Piece]:
    """This rank's parts of the checkpoint: its slab rows of the damage; on a group root the
    2-D fields and state of its items; on world rank 0 the records of every item."""
    pieces = []
    for iid, run in study.runs.items():
        rows = run.cycle.slab.rows
        st = run.state
        for b, bs in enumerate(st.bodies, start=1):
            for f in BODY_FIELDS:
                data = getattr(bs, f.name)
                if f.layered:     # every rank its slab rows
                    pieces.append(Piece(iid, f"body{b}/{f.name}", data,
                                        (slice(None), slice(rows.start, rows.stop))))
                elif study.group.is_root:
                    pieces.append(Piece(iid, f"body{b}/{f.name}", data.astype(f.dtype,
                                                                               copy=False)))
        if study.group.is_root:
            pieces.append(Piece(iid, "state", item_state_row(st)))
    if study.comm.rank == 0:
        for iid, recs in records.items():
            tab = np.full((study.blocks, len(RECORD_FIELDS)), np.nan)
            for j, r in enumerate(recs):
                tab[j] = record_row(r)
            pieces.append(Piece(iid, "records", tab))
    return pieces


def _check_compatible(path: Path, attrs: dict, study: Study, scene: Scene, force: bool,
                      surfaces: dict[str, str]) -> None:
    """Refuse a checkpoint of another scene or of other measured-surface files (unless
    ``force``), or of other work items."""
    if attrs.get("items") != _items_json(study):
        raise CheckpointError(
            f"{path} holds other work items than {scene.source} with these options "
            f"(positions, wear coefficients, roughness scales, patches); a restart cannot map "
            f"them: restart with the same scene and --position options, or use a new --out")
    if attrs.get("scene") != scene_json(scene.document) and not force:
        old = json.loads(attrs.get("scene", "{}"))
        new = json.loads(scene_json(scene.document))
        diff = sorted(_differences(old, new))
        shown = ", ".join(diff[:6]) + (" …" if len(diff) > 6 else "")
        raise CheckpointError(
            f"{path} was written for a different scene (from {attrs.get('scene_file')}); "
            f"keys that differ: {shown or 'formatting only'}. Restart with the scene it was "
            f"written for, or pass --force to continue with {scene.source}")
    before = json.loads(attrs.get("surface_files") or "{}")
    for name, digest in surfaces.items():
        if before.get(name, digest) != digest and not force:
            raise CheckpointError(
                f"{path}: the measured surface {name} changed since the checkpoint was "
                f"written (SHA-256 {before[name][:12]}… then, {digest[:12]}… now); restore "
                "the file, or pass --force to continue on the new one")


def _differences(a, b, prefix: str = "") -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            out += _differences(a.get(k), b.get(k), f"{prefix}{k}.")
        return out
    return [] if a == b else [prefix.rstrip(".")]


def _read_state(path: Path, study: Study) -> tuple[int, dict[int, list[BlockRecord]]]:
    """Load every item's state of this rank from ``path``; returns the blocks done and (on
    world rank 0) the records. Collective."""
    requests = []
    for iid, run in study.runs.items():
        rows = run.cycle.slab.rows
        requests.append((iid, "state", None))
        for b in (1, 2):
            requests += [(iid, f"body{b}/{f.name}", (slice(None), slice(rows.start, rows.stop))
                          if f.layered else None) for f in BODY_FIELDS]
    if study.comm.rank == 0:
        requests += [(it.id, "records", None) for it in study.items]
    attrs, data = read_checkpoint(path, study.comm, requests)
    done = int(attrs["block"])
    for iid, run in study.runs.items():
        st = run.state
        restore_item_state(st, data[(iid, "state")])
        for b, bs in enumerate(st.bodies, start=1):
            for f in BODY_FIELDS:
                arr = np.array(data[(iid, f"body{b}/{f.name}")])
                setattr(bs, f.name, arr.astype(bool) if f.dtype == "u1" else
                        arr.astype(float))
            if bs.damage.shape != run.cycle.slab.local_shape:
                raise CheckpointError(f"{path}: damage of item {iid} has shape "
                                      f"{bs.damage.shape}, this window needs "
                                      f"{run.cycle.slab.local_shape}")
    records: dict[int, list[BlockRecord]] = {it.id: [] for it in study.items}
    problem = None
    if study.comm.rank == 0:
        for it in study.items:
            tab = data[(it.id, "records")]
            if tab.shape[-1] != len(RECORD_FIELDS):
                problem = (f"{path}: block records of {tab.shape[-1]} columns, this version "
                           f"writes {len(RECORD_FIELDS)}; restart with the version that "
                           "wrote it")
                break
            records[it.id] = [record_from_row(r) for r in tab[:done] if np.isfinite(r[0])]
    raise_agreed(study.comm, problem, CheckpointError)
    return done, records


def _inspect(path: Path, study: Study, scene: Scene, force: bool,
             surfaces: dict[str, str]) -> tuple[str, list[float] | None]:
    """Check that the checkpoint ``path`` can resume ``study`` (rank 0 reads it once, every
    rank gets the verdict: CheckpointError everywhere or nowhere) and return each item's last
    block time from it (None when not all are known) for the longest-first assignment,
    with the run id the checkpoint carries."""
    def inspect() -> tuple[str | None, list[float] | None]:
        attrs = read_attrs(path)   # verified by find_latest
        _check_compatible(path, attrs, study, scene, force, surfaces)
        done = int(attrs["block"])
        if done > study.blocks:
            raise CheckpointError(f"{path} is block {done}, beyond this scene's "
                                  f"{study.blocks} blocks (life.cycles_M / life.block_M)")
        with h5py_module().File(path, "r") as f:
            wall = f["records"][:, done - 1, RECORD_FIELDS.index("wall_s")]
        costs = [float(c) for c in wall] if np.all(np.isfinite(wall)) else None
        return attrs.get("run_id"), costs

    return from_root(study.comm, inspect, CheckpointError, world=True)


class Handler:
    """A part attached to the study loop (:func:`run_study`): progress, warnings, results.
    Every method is called on every rank at the same point (so a handler may make collective
    calls, on every rank alike); the defaults do nothing.

    ``start(study, blocks, start)``: before the first block (``start`` blocks already done by
    a restart); ``progress(k, item, i, n, cycles_done, block_cycles, sub_block, step,
    steps, queued)``: after every time step inside block ``k``, on the ranks of the group that
    runs ``item`` (the i-th of its n items, or, ``queued``, the i-th handed out of the block's
    n, :class:`~micropit_hpc.study.Study`); ``block(k, blocks, records)``: after block ``k`` and
    its checkpoint, with every item's records so far; ``finish(outcome)``: once the loop ends
    (done or stopped at a block boundary), not after an error."""

    def start(self, study: Study, blocks: int, start: int) -> None:
        pass

    def progress(self, k: int, item, i: int, n: int, cycles_done: float,
                 block_cycles: float, sub_block: int, step: int, steps: int,
                 queued: bool = False) -> None:
        pass

    def block(self, k: int, blocks: int, records: dict[int, list[BlockRecord]]) -> None:
        pass

    def finish(self, outcome: RunOutcome) -> None:
        pass


class Checkpoints(Handler):
    """The loop's own handler: a checkpoint every ``every`` blocks and after the last
    (:func:`~micropit_hpc.io.checkpoint.write_checkpoint`), and one for a stop
    (:meth:`ensure`)."""

    def __init__(self, study: Study, opts: RunOptions, records, attrs: dict, start: int):
        self.study, self.records, self.attrs = study, records, attrs
        self.directory, self.every, self.keep = (Path(opts.out) / CHECKPOINT_DIR,
                                                 opts.checkpoint_every, opts.keep)
        self.specs = _field_specs(study)
        self.written, self.seconds = start, 0.0   # the last block written, its time

    def write(self, k: int) -> Path:
        t0 = time.perf_counter()
        with stage("checkpoint"):
            path = write_checkpoint(self.directory, self.study.comm, k, len(self.study.items),
                                    self.specs, _pieces(self.study, self.records), self.attrs,
                                    keep=self.keep)
        self.written, self.seconds = k, time.perf_counter() - t0
        return path

    def block(self, k: int, blocks: int, records) -> None:
        if k % self.every == 0 or k == blocks:
            self.write(k)

    def ensure(self, k: int) -> None:
        """Block ``k`` checkpointed (before a stop)."""
        if self.written != k:
            self.write(k)


def run_study(scene: Scene, opts: RunOptions, comm,
              log: Callable[[str], None] = lambda s: None,
              handlers: Sequence[Handler] = (),
              control: StopControl | None = None,
              plan: Plan | None = None) -> RunOutcome:
    """Run (or resume) every work item of ``scene`` on ``comm`` (collective), telling the
    ``handlers`` (:class:`Handler`) as it goes; the checkpoints are the loop's own handler
    (:class:`Checkpoints`), told first. ``control``: the stop control to ask at each block
    boundary (default: one made here from ``opts``, closed at the end; the CLI passes its
    own, which keeps the signals handled until the results are written). ``plan``: the
    scene's checked :class:`~micropit_hpc.plan.Plan` (default: made here)."""
    rank0 = comm.rank == 0
    ckdir = Path(opts.out) / CHECKPOINT_DIR
    latest = None
    surfaces = from_root(comm, lambda: surface_files(scene), CheckpointError, world=True)
    with stage("setup"):
        study = Study(scene, comm, opts.ranks_per_item, opts.positions, log, plan=plan,
                      balance=opts.balance)
        if opts.restart:
            latest = find_latest(ckdir, comm, expect=_expected(study),
                                 on_skip=lambda e: log(f"skipped {e}") if rank0 else None)
            if latest is None:
                log(f"--restart: no usable checkpoint in {ckdir}; starting from the "
                    "beginning")
        run_id, costs = (_inspect(latest, study, scene, opts.force, surfaces)
                         if latest is not None else (None, None))
        if run_id is None:
            run_id = from_root(comm, lambda: uuid.uuid4().hex)
        if latest is not None:    # the states are read into the items' groups: no queue
            study.assign(costs)
        study.setup()
    records: dict[int, list[BlockRecord]] = {it.id: [] for it in study.items}
    start = 0
    if latest is not None:
        with stage("restart"):
            start, records = _read_state(latest, study)
        log(f"restarted from {latest} (block {start} of {study.blocks}, "
            f"{'round robin' if costs is None else 'longest-first by last block time'})")
    ckpt = Checkpoints(study, opts, records, _attrs(study, scene, run_id, surfaces)
                       if rank0 else {}, start)
    attached = (ckpt, *handlers)

    def progress(*args) -> None:
        for h in attached:
            h.progress(*args)

    for h in attached:
        h.start(study, study.blocks, start)
    own = control is None
    if own:
        control = StopControl(comm, opts.stop_file, opts.max_wall_s)
    done, outcome = start, None
    longest = 0.0   # the longest block so far, with its checkpoint
    try:
        for k in range(start + 1, study.blocks + 1):
            t0 = time.perf_counter()
            with stage("blocks"):
                for iid, rec in study.run_block(k, progress).items():
                    records[iid].append(rec)
            done = k
            for h in attached:
                h.block(k, study.blocks, records)
            if k == study.blocks:
                break
            longest = max(longest, time.perf_counter() - t0)
            # the next block may be longer than any so far (adaptive splits): 20 % margin,
            # plus a checkpoint for the stop itself
            reason = control.reason(next_block_s=NEXT_BLOCK_MARGIN * longest + ckpt.seconds)
            if reason:
                ckpt.ensure(k)
                log(f"stopping after block {k} of {study.blocks}: {reason}; checkpoint "
                    f"{ckdir / checkpoint_name(k)} written; continue with --restart")
                outcome = RunOutcome("stopped", done, start, records, reason, study, run_id)
                break
        if outcome is None:
            if start == study.blocks:
                log(f"the checkpoint is already at the last block ({start}); writing the "
                    "results")
            outcome = RunOutcome("done", done, start, records, None, study, run_id)
        for h in attached:
            h.finish(outcome)
    finally:
        if own:
            control.close()
    return outcome
