"""Triggers: each fires exactly once along a random route; the position-jump policy; polygon enter/leave."""

from __future__ import annotations

import math

import numpy as np

from eddie.annotated_map import Annotation, AnnotationDatabase, Location, TriggerWalker


def _gate(aid: str, x: float, *, refire: bool = False) -> Annotation:
    """A line across the x axis at `x` (a trigger line across the road)."""
    return Annotation(id=aid, type="set_speed", destination="controller", trigger="cross", refire=refire,
                      location=Location.line([(x, -2.0), (x, 2.0)]))


def test_every_trigger_on_a_random_route_fires_exactly_once() -> None:
    rng = np.random.default_rng(11)
    # a random wandering route, sampled at irregular cycle lengths
    heading, p = 0.0, np.zeros(2)
    route = [p.copy()]
    for _ in range(400):
        heading += rng.normal(0, 0.15)
        p = p + rng.uniform(0.05, 1.5) * np.array([math.cos(heading), math.sin(heading)])
        route.append(p.copy())
    line = np.array(route)
    anns = []
    # triggers placed on the route: short lines across it, and points with a reach
    for k in range(60):
        i = int(rng.integers(1, len(line) - 1))
        t = rng.uniform(0, 1)
        c = line[i] + t * (line[i + 1] - line[i])
        d = line[i + 1] - line[i]
        nrm = np.array([-d[1], d[0]]) / (np.linalg.norm(d) + 1e-12)
        if k % 2:
            anns.append(Annotation(id=f"t{k}", type="x", destination="m", trigger="cross",
                                   location=Location.line([tuple(c - 0.6 * nrm), tuple(c + 0.6 * nrm)])))
        else:
            anns.append(Annotation(id=f"t{k}", type="x", destination="m", trigger="cross", reach=0.3,
                                   location=Location.point(*(c + rng.uniform(-0.2, 0.2) * nrm))))
    # and decoys well off the route that must never fire
    for k in range(20):
        anns.append(Annotation(id=f"far{k}", type="x", destination="m", trigger="cross",
                               location=Location.point(1e4 + k, 1e4)))
    db = AnnotationDatabase(anns)
    w = TriggerWalker(db)
    w.reset(*line[0])
    fired: list[str] = []
    for q in line[1:]:
        fired += [e.annotation.id for e in w.advance(*q) if e.kind == "fired"]
    on_route = sorted(a.id for a in anns if not a.id.startswith("far"))
    assert sorted(fired) == on_route
    assert len(fired) == len(set(fired))
    assert all(db.get(i).used for i in on_route)
    # driving the same route again fires nothing
    w.reset(*line[0])
    assert not [e for q in line[1:] for e in w.advance(*q)]


def test_triggers_fire_in_travel_order_within_one_cycle() -> None:
    db = AnnotationDatabase([_gate("b", 3.0), _gate("a", 1.0), _gate("c", 5.0)])
    w = TriggerWalker(db)
    w.reset(0, 0)
    assert [e.annotation.id for e in w.advance(6, 0)] == ["a", "b", "c"]


def test_small_forward_jump_fires_what_it_crosses() -> None:
    db = AnnotationDatabase([_gate("g", 5.0)])
    w = TriggerWalker(db)
    w.reset(0, 0)
    assert w.advance(4.0, 0) == []
    ev = w.jump(5.5, 0)  # 1.5 m forward
    assert [(e.annotation.id, e.kind, e.via) for e in ev] == [("g", "fired", "small_forward")]


def test_large_forward_jump_skips_and_reports() -> None:
    db = AnnotationDatabase([_gate("g1", 5.0), _gate("g2", 7.0), _gate("g3", 12.0)])
    w = TriggerWalker(db)
    w.reset(0, 0)
    w.advance(4.0, 0)
    ev = w.jump(9.0, 0.5)  # 5 m forward
    assert [(e.annotation.id, e.kind) for e in ev] == [("g1", "skipped"), ("g2", "skipped")]
    assert all(e.skipped for e in ev)
    # the skipped ones are used: driving on fires only the next one
    assert [e.annotation.id for e in w.advance(13.0, 0.5)] == ["g3"]
    assert db.get("g1").used and db.get("g2").used


def test_backward_jump_does_not_refire_unless_the_trigger_says_so() -> None:
    db = AnnotationDatabase([_gate("once", 5.0), _gate("again", 6.0, refire=True)])
    w = TriggerWalker(db)
    w.reset(0, 0)
    assert [e.annotation.id for e in w.advance(7.0, 0)] == ["once", "again"]
    back = w.jump(4.0, 0)  # 3 m backward
    assert [(e.annotation.id, e.kind, e.via) for e in back] == [("again", "rearmed", "backward")]
    assert [e.annotation.id for e in w.advance(8.0, 0)] == ["again"]


def test_small_backward_jump_fires_nothing() -> None:
    db = AnnotationDatabase([_gate("g", 5.0)])
    w = TriggerWalker(db)
    w.reset(0, 0)
    w.advance(6.0, 0)
    assert db.get("g").used
    assert w.jump(4.5, 0) == []
    assert w.advance(6.0, 0) == []


def test_polygon_enter_and_leave() -> None:
    square = Location.polygon([(2, -1), (4, -1), (4, 1), (2, 1)])
    db = AnnotationDatabase([
        Annotation(id="in", type="zone", destination="vision", trigger="enter", location=square),
        Annotation(id="out", type="zone", destination="vision", trigger="leave", location=square),
    ])
    w = TriggerWalker(db)
    w.reset(0, 0)
    assert [e.annotation.id for e in w.advance(1.9, 0)] == []
    ev = w.advance(2.6, 0.1)
    assert [(e.annotation.id, e.edge) for e in ev] == [("in", "enter")]
    assert abs(ev[0].x - 2.0) < 1e-6
    assert w.advance(3.5, 0.2) == []
    ev = w.advance(5.0, 0.2)
    assert [(e.annotation.id, e.edge) for e in ev] == [("out", "leave")]
    assert abs(ev[0].x - 4.0) < 1e-6



def test_polygon_passed_through_in_one_cycle_fires_enter_then_leave() -> None:
    square = Location.polygon([(2, -1), (4, -1), (4, 1), (2, 1)])
    db = AnnotationDatabase([
        Annotation(id="out", type="zone", destination="vision", trigger="leave", location=square),
        Annotation(id="in", type="zone", destination="vision", trigger="enter", location=square),
    ])
    w = TriggerWalker(db)
    w.reset(0, 0.5)
    ev = w.advance(6, 0.5)
    assert [(e.annotation.id, round(e.x, 6)) for e in ev] == [("in", 2.0), ("out", 4.0)]


def test_starting_inside_a_polygon_does_not_fire_enter() -> None:
    square = Location.polygon([(-1, -1), (1, -1), (1, 1), (-1, 1)])
    db = AnnotationDatabase([Annotation(id="out", type="zone", destination="v", trigger="leave", location=square),
                             Annotation(id="in", type="zone", destination="v", trigger="enter", location=square)])
    w = TriggerWalker(db)
    w.reset(0, 0)
    assert [e.annotation.id for e in w.advance(3, 0)] == ["out"]
