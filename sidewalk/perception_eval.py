"""Evaluate PERCEPTION against ground truth: per-class IoU of colour, range and colored-range
segmentation, position-fix error, processing time. Pure: frames come in as data (the composition root
captures them from the simulator), so this file knows nothing of `vehicle_sim`.

Segmentation IoU scores what a segmentation can separate, not a recogniser: every patch is given the
ground-truth class that covers most of it, then per-class IoU = TP / (TP + FP + FN) is accumulated over
all frames on the pixels that have ground truth and data (the same pixels for all three methods).
Each frame starts from fresh colour classes (the map's nominal colours) fitted to that frame alone,
as on PERCEPTION's first frame at a place: the figures do not depend on the order of the frames.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Iterable

import numpy as np

from modules.perception.image import ColoredRangeImage
from modules.perception.patch_maker import Segmentation
from modules.perception.pipeline import PerceptionPipeline, PipelineOutput
from modules.perception.results import build_result
from modules.perception.sensor_frame import SensorFrame, colored_range_image
from modules.vocabulary import DrivingUnitDescription, MapObject
from wire.se2 import wrap_angle
from wire.summary import percentile

__all__ = [
    "EvalFrame",
    "IouAccumulator",
    "oracle_labels",
    "FixErrors",
    "EvaluationReport",
    "evaluate",
    "FOCUS_CLASSES",
]

#: The classes of the paper's claim (Sidewalk 1986 §3.4.5).
FOCUS_CLASSES: tuple[str, ...] = ("slope", "stairs", "grass")


@dataclass(frozen=True)
class EvalFrame:
    """One captured frame with its truth: image, (H, W) int class labels into `class_names`, true pose.

    `truth_pose` and `prior_pose` are world←vehicle (x [m], y [m], yaw [rad]); `objects` the map's
    predicted objects near the view (what a driving unit would carry); `sensor` the raw capture the
    image was registered from (the timed cycle starts there), `capture_s` [s] wall the capture took.
    """

    image: ColoredRangeImage
    labels: np.ndarray
    class_names: tuple[str, ...]
    truth_pose: tuple[float, float, float]
    prior_pose: tuple[float, float, float]
    objects: tuple[MapObject, ...]
    capture_s: float = 0.0
    sensor: SensorFrame | None = None


def oracle_labels(patch_ids: np.ndarray, truth: np.ndarray, scored: np.ndarray, n_classes: int) -> np.ndarray:
    """Give each patch the majority truth class of its scored pixels; (H, W) int (-1 = no patch)."""
    out = np.full(patch_ids.shape, -1, dtype=np.int64)
    ids = patch_ids[scored]
    cls = truth[scored]
    have = ids > 0
    if not have.any():
        return out
    n_ids = int(patch_ids.max()) + 1
    hist = np.bincount(ids[have] * n_classes + cls[have], minlength=n_ids * n_classes).reshape(n_ids, n_classes)
    best = np.argmax(hist, axis=1)
    best[hist.sum(axis=1) == 0] = -1
    best[0] = -1
    return best[patch_ids]


@dataclass
class IouAccumulator:
    """Accumulate TP, FP and FN per class over frames."""

    n_classes: int
    tp: np.ndarray = field(init=False)
    fp: np.ndarray = field(init=False)
    fn: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.tp = np.zeros(self.n_classes, np.int64)
        self.fp = np.zeros(self.n_classes, np.int64)
        self.fn = np.zeros(self.n_classes, np.int64)

    def add(self, pred: np.ndarray, truth: np.ndarray, scored: np.ndarray) -> None:
        """Add one frame: predicted (H, W) int (-1 none), truth (H, W) int, scored (H, W) bool."""
        p = pred[scored]
        t = truth[scored]
        k = self.n_classes
        hit = p == t
        self.tp += np.bincount(t[hit], minlength=k)[:k]
        self.fn += np.bincount(t[~hit], minlength=k)[:k]
        pp = p[(~hit) & (p >= 0)]
        self.fp += np.bincount(pp, minlength=k)[:k]

    def iou(self) -> np.ndarray:
        """Return (n_classes,) IoU (NaN where a class never appeared)."""
        den = self.tp + self.fp + self.fn
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(den > 0, self.tp / np.maximum(den, 1), np.nan)


@dataclass(frozen=True)
class FixErrors:
    """Position-fix errors against truth: translation [m] (across the line for line fixes), heading [rad]."""

    kind: str
    translation: float
    heading: float | None
    prior_translation: float
    prior_heading: float


@dataclass(frozen=True)
class EvaluationReport:
    """Everything `sidewalk perception eval` prints (a plain, JSON-ready dict via `as_dict`)."""

    frames: int
    focus_frames: int
    class_names: tuple[str, ...]
    iou_all: dict[str, dict[str, float]]
    iou_focus: dict[str, dict[str, float]]
    mean_focus: dict[str, dict[str, float]]
    fixes: tuple[FixErrors, ...]
    failures: tuple[str, ...]
    cycle_ms: tuple[float, ...]
    capture_ms: tuple[float, ...]
    segment_ms: dict[str, tuple[float, ...]]
    resolution_steps: dict[int, int]
    cycle_cpu_ms: tuple[float, ...] = ()

    def as_dict(self) -> dict:
        """Return the report as JSON-ready data."""


        pts = [f for f in self.fixes if f.kind == "point"]
        lines = [f for f in self.fixes if f.kind == "line"]

        def fixstats(fs: list[FixErrors]) -> dict:
            hd = [abs(f.heading) for f in fs if f.heading is not None]
            return {
                "count": len(fs),
                "translation_m_p50": percentile([f.translation for f in fs], 50),
                "translation_m_p95": percentile([f.translation for f in fs], 95),
                "heading_deg_p50": math.degrees(percentile(hd, 50)) if hd else None,
                "heading_deg_p95": math.degrees(percentile(hd, 95)) if hd else None,
                "prior_translation_m_p50": percentile([f.prior_translation for f in fs], 50),
                "prior_heading_deg_p50": math.degrees(percentile([abs(f.prior_heading) for f in fs], 50)) if fs else None,
            }

        return {
            "frames": self.frames,
            "focus_frames": self.focus_frames,
            "iou_all": self.iou_all,
            "iou_focus": self.iou_focus,
            "mean_iou_focus": self.mean_focus,
            "position_fix": {"point": fixstats(pts), "line": fixstats(lines), "failed": len(self.failures),
                             "failure_reasons": sorted(set(self.failures))[:10]},
            "cycle_ms_p50": percentile(self.cycle_ms, 50),
            "cycle_ms_p95": percentile(self.cycle_ms, 95),
            "cycle_cpu_ms_p50": percentile(self.cycle_cpu_ms, 50),
            "capture_ms_p50": percentile(self.capture_ms, 50),
            "capture_ms_p95": percentile(self.capture_ms, 95),
            "segment_ms_p50": {k: percentile(v, 50) for k, v in self.segment_ms.items()},
            "segment_ms_p95": {k: percentile(v, 95) for k, v in self.segment_ms.items()},
            "resolution_steps": {str(k): v for k, v in self.resolution_steps.items()},
        }


def _iou_dict(acc: IouAccumulator, names: tuple[str, ...], keep: Iterable[str]) -> dict[str, float]:
    iou = acc.iou()
    return {n: round(float(iou[names.index(n)]), 4) for n in keep if n in names and not np.isnan(iou[names.index(n)])}


def fix_errors(out: PipelineOutput, truth: tuple[float, float, float], prior: tuple[float, float, float]) -> FixErrors | None:
    """Compare a pipeline's fix with the true pose."""
    cal = out.calibration
    if cal is None:
        return None
    d = np.array(cal.pose[:2]) - np.array(truth[:2])
    prior_t = float(math.hypot(prior[0] - truth[0], prior[1] - truth[1]))
    prior_h = wrap_angle(prior[2] - truth[2])
    if cal.kind == "line":
        n = np.array([-math.sin(cal.line_direction), math.cos(cal.line_direction)])
        trans = float(abs(d @ n))
    else:
        trans = float(np.linalg.norm(d))
    heading = wrap_angle(cal.pose[2] - truth[2]) if cal.yaw_known else None
    return FixErrors(cal.kind, trans, heading, prior_t, prior_h)


def evaluate(frames: Iterable[EvalFrame], pipeline: PerceptionPipeline, *, focus_min_fraction: float = 0.02,
             error_allowance: float = 0.5) -> EvaluationReport:
    """Score the three segmentations, the fixes and the processing time over the frames.

    `error_allowance` [m] is what a driving unit would carry (the prior pose's uncertainty).
    """
    accs: dict[str, IouAccumulator] = {}
    accs_focus: dict[str, IouAccumulator] = {}
    fixes: list[FixErrors] = []
    failures: list[str] = []
    cycle: list[float] = []
    cycle_cpu: list[float] = []
    capture: list[float] = []
    seg_ms: dict[str, list[float]] = {m.value: [] for m in Segmentation}
    names: tuple[str, ...] = ()
    steps: dict[int, int] = {}
    n = nf = 0
    for fr in frames:
        names = fr.class_names
        k = len(names)
        for m in Segmentation:
            accs.setdefault(m.value, IouAccumulator(k))
            accs_focus.setdefault(m.value, IouAccumulator(k))
        img = fr.image
        scored = img.valid & (fr.labels >= 0)
        # the paper's scene (§3.4.5): slope, stairs and grass in one view
        present = [c for c in FOCUS_CLASSES if c in names]
        fracs = [float((fr.labels[scored] == names.index(c)).mean()) if scored.any() else 0.0 for c in present]
        is_focus = len(present) == len(FOCUS_CLASSES) and min(fracs) >= focus_min_fraction
        n += 1
        nf += int(is_focus)
        for m in Segmentation:
            model = pipeline.colour_model_for(fr.objects) if m is not Segmentation.RANGE else None
            t0 = time.perf_counter()
            seg = pipeline.segment(img, fr.objects, fr.prior_pose, m, error_allowance=error_allowance, model=model)
            seg_ms[m.value].append(1000 * (time.perf_counter() - t0))
            pred = oracle_labels(seg.patches.ids, fr.labels, scored, k)
            accs[m.value].add(pred, fr.labels, scored)
            if is_focus:
                accs_focus[m.value].add(pred, fr.labels, scored)
        # the cycle: from the captured frame to the driving unit result (registration, patches, objects, fix)
        t0, c0 = time.perf_counter(), time.process_time()
        work = colored_range_image(fr.sensor, pool=pipeline.pool) if fr.sensor is not None else img
        out = pipeline.process(work, fr.objects, fr.prior_pose, error_allowance=error_allowance)
        build_result(_unit_for(fr), out, fr.prior_pose, img.stamp, work)
        cycle.append(1000 * (time.perf_counter() - t0))
        cycle_cpu.append(1000 * (time.process_time() - c0))
        steps[out.plan.step] = steps.get(out.plan.step, 0) + 1
        capture.append(1000 * fr.capture_s)
        if out.failure:
            failures.append(out.failure)
        fe = fix_errors(out, fr.truth_pose, fr.prior_pose)
        if fe is not None:
            fixes.append(fe)
    shown = [c for c in names if c not in ("none", "sky")]
    iou_all = {m: _iou_dict(a, names, shown) for m, a in accs.items()}
    iou_focus = {m: _iou_dict(a, names, shown) for m, a in accs_focus.items()}
    mean_focus = {}
    for m, a in accs_focus.items():
        iou = a.iou()
        vals = [iou[names.index(c)] for c in FOCUS_CLASSES if c in names]
        vals = [v for v in vals if not np.isnan(v)]
        mean_focus[m] = {"mean_iou": round(float(np.mean(vals)), 4) if vals else float("nan")}
    return EvaluationReport(n, nf, names, iou_all, iou_focus, mean_focus, tuple(fixes), tuple(failures),
                            tuple(cycle), tuple(capture), {k: tuple(v) for k, v in seg_ms.items()}, dict(sorted(steps.items())),
                            tuple(cycle_cpu))


def _unit_for(fr: EvalFrame) -> DrivingUnitDescription:
    """Return a driving unit for a frame: the ground 5–10 m ahead of the prior pose, the frame's objects."""
    x, y, yaw = fr.prior_pose
    c, s = math.cos(yaw), math.sin(yaw)
    ring = tuple((x + c * a - s * b, y + s * a + c * b) for a, b in ((5, -1.5), (10, -1.5), (10, 1.5), (5, 1.5)))
    return DrivingUnitDescription(unit_id="eval.u0", segment_id="eval", unit_index=0, mode="follow-road", region=ring,
                                  centreline=((x + 5 * c, y + 5 * s), (x + 10 * c, y + 10 * s)), objects=fr.objects)
