"""YARF's intersection navigation (Navlab 1990 §5.6): the approach seen coming, the branch located, the path into its lane."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.road_following import CameraGeometry, Spine, VehicleMotion, Yarf

pytestmark = pytest.mark.timeout(180)  # quiet run ~25 s (simulator frames and the local map on each; measured under load)


@pytest.fixture(scope="module")
def schenley():
    from tests.modules._road_frames import route_frames

    return route_frames("schenley")


def test_the_intersection_is_seen_coming_its_branch_located_and_the_path_ends_in_the_lane(schenley) -> None:
    from modules.road_following.yarf_intersection import IntersectionNavigator
    from sidewalk.roadfollow_eval import DrivePose, to_vehicle

    rng = np.random.default_rng(5)
    # Golf Course Rd runs east (y = 0) into the intersection at x 214–226; Tee Dr leaves north along x = 220
    poses = [DrivePose(leg=0, x=x, y=-1.75, yaw=0.0, stamp=x / 4.2) for x in np.arange(170.0, 212.0, 2.0)]
    yarf = nav = None
    first_seen = None
    for fr, cap in schenley.frames(poses, rng):
        if yarf is None:
            cam = CameraGeometry.from_capture(cap)
            yarf, nav = Yarf(cam, prior=Spine(offset=1.75)), IntersectionNavigator(cam, turn="left")
            motion = None
        else:
            motion = VehicleMotion(dx=2.0)
        view = nav.observe(fr.image, motion, yarf.observe(fr.image, stamp=fr.pose.stamp, motion=motion))
        if view.approach_m is not None and first_seen is None:
            first_seen = 214.0 - fr.pose.x
            assert abs(view.approach_m - first_seen) < 3.0
    assert first_seen is not None and 10.0 < first_seen < 35.0  # not before the camera could see the gap, and not at the kerb
    assert view.branch is not None
    # where it leaves the road: within two steps of the search (0.5 m); its angle a tie of the rotation with that shift
    assert abs(view.branch.along_m - (220.0 - fr.pose.x)) <= 1.0 and abs(math.degrees(view.branch.angle_rad) - 90.0) < 3.0
    end = np.asarray(view.path[-1]) + (fr.pose.x, fr.pose.y)  # the vehicle heads east: vehicle axes are world axes
    assert abs(end[0] - (220.0 + 1.75)) < 0.5 and end[1] > 10.0  # in Tee Dr's right lane, northbound
    # told to turn right, it finds Tee Dr's south arm instead
    nav_r = IntersectionNavigator(cam, turn="right")
    nav_r.map, nav_r.start, nav_r.start_dir, nav_r.spine = nav.map, nav.start, nav.start_dir, nav.spine
    nav_r._find_branch()
    d = nav_r.branch[1]
    assert abs(math.degrees(math.atan2(d[1], d[0])) + 90.0) < 3.0
