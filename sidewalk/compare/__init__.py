"""`sidewalk compare`: the blackboard (CODGER) and EDDIE on the same missions, seeds and faults, measured."""

from sidewalk.compare.errors import CompareError
from sidewalk.compare.faults import FAULTS, FaultSpec, parse_fault
from sidewalk.compare.glue import GlueCount, count_glue, logical_lines
from sidewalk.compare.latency import LatencySeries, read_latencies, sense_to_act_s, unit_latency_s
from sidewalk.compare.measures import RunMeasures, measure_run
from sidewalk.compare.summary import ArchSummary, Spread, spread, summarise, within_spread

__all__ = [
    "CompareError", "FAULTS", "FaultSpec", "parse_fault", "GlueCount", "count_glue", "logical_lines", "LatencySeries",
    "read_latencies", "sense_to_act_s", "unit_latency_s", "RunMeasures", "measure_run", "ArchSummary", "Spread", "spread",
    "summarise", "within_spread",
]
