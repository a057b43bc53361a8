"""`sidewalk run`, `up`, `submit`, `status`, `cancel`: run missions and operate a live system."""

from __future__ import annotations

import asyncio
import importlib
import math
import sys
from pathlib import Path
from typing import Annotated, Callable, Optional

import typer

from wire.network import NetworkConfig
from sidewalk.processes import UP_TARGETS
from wire.flags import with_network

__all__ = ["register", "UP_TARGETS"]


#: RunConfig field → the `sidewalk run` flag that sets it (for errors naming the flag).
_FLAGS = {"rtf": "--rtf", "max_sim_time_s": "--max-sim-time", "max_wall_time_s": "--max-wall-time",
          "pose_error_m": "--pose-error", "map_error_m": "--map-error", "monitor_port": "--monitor-port",
          "max_speed": "--max-speed", "map_file": "--map"}


def _parse_pose_error(text: str) -> tuple[float, float]:
    parts = text.split(",")
    try:
        m, deg = (float(p) for p in parts)
    except ValueError:
        raise typer.BadParameter(f"{text!r} is not M,DEG (metres and degrees, e.g. 1.5,3)", param_hint="--pose-error") from None
    if not (math.isfinite(m) and math.isfinite(deg)) or m < 0:
        raise typer.BadParameter(f"{text!r}: metres must be ≥ 0 and both finite", param_hint="--pose-error")
    return m, deg


# ---- monitor and recording (issue 11) ----
#: Progress steps shown before the monitor process has said it is ready.
_BEFORE_MONITOR = ("starting", "starting router", "starting blackboard", "starting recorder", "starting monitor")


def _monitor_preflight(cfg, console) -> Optional[str]:  # noqa: ANN001 - RunConfig, rich Console
    """Return the monitor page's URL (None without --monitor); exit 2 with one line if its port is taken."""
    if cfg.monitor_port is None:
        return None
    from sidewalk.monitor import PortInUseError, check_port
    from sidewalk.observers import monitor_url

    try:
        check_port("127.0.0.1", cfg.monitor_port)
    except PortInUseError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    return monitor_url(cfg.monitor_port)
# ---- end monitor and recording ----


def run(
    world: Annotated[Optional[str], typer.Option(help="World name (worlds/<name>.world.geojson) or file (default: the mission's world, else campus); the robot gets its map (NAME.map.geojson beside it), never the world")] = None,
    mission: Annotated[str, typer.Option(help="Mission name (worlds/<name>.yaml) or file")] = "campus-tour",
    vehicle: Annotated[Optional[str], typer.Option(help="terregator or navlab (default: the mission's, else terregator)")] = None,
    rtf: Annotated[float, typer.Option(help="Real-time factor of the simulator")] = 20.0,
    seed: Annotated[int, typer.Option(help="Seed: the run is reproducible from it")] = 0,
    out: Annotated[Path, typer.Option(help="Directory for report.json, trajectory.png, logs/")] = Path("runs/latest"),
    no_perception: Annotated[bool, typer.Option("--no-perception", help="Run without PERCEPTION: the PILOT dead-reckons on the map")] = False,
    pose_error: Annotated[str, typer.Option(help="Pose error M,DEG added to the start the PILOT is told (the mission's start, else the map's)")] = "0,0",
    map_error: Annotated[Optional[float], typer.Option(help="Give the robot a map derived with error M [m]: offset, rotation, scattered vertices, missing objects; M is the largest vertex displacement (default: the shipped map)")] = None,
    max_sim_time: Annotated[float, typer.Option(help="Give up after this much sim time [s]")] = 3600.0,
    max_wall_time: Annotated[float, typer.Option(help="Give up after this much wall time [s]")] = 1800.0,
    ns: Annotated[Optional[str], typer.Option("--ns", help="Namespace (default: a fresh one per run)")] = None,
    arch: Annotated[str, typer.Option("--arch", help="codger (the blackboard system) or eddie (EDDIE: controller, navigator, annotated maps; no blackboard)")] = "codger",
    # ---- monitor and recording (issue 11) ----
    monitor: Annotated[bool, typer.Option("--monitor", help="Serve the NAVIGATION MONITOR page for the run (prints its URL)")] = False,
    monitor_port: Annotated[int, typer.Option("--monitor-port", help="HTTP port of the monitor page")] = 8080,
    no_record: Annotated[bool, typer.Option("--no-record", help="Do not write run.mcap")] = False,
    # ---- end monitor and recording ----
    secure: Annotated[Optional[Path], typer.Option("--secure", help="Secure directory (`sidewalk security init`): every process on mutual TLS with a password, the router enforcing its rules.yaml")] = None,
    actors: Annotated[Optional[str], typer.Option("--actors", help="Objects not on the map: an actors file (JSON/YAML) or a preset (e.g. amv-delivery)")] = None,
    obstacles: Annotated[Optional[bool], typer.Option("--obstacles/--no-obstacles", help="Run the OBSTACLE DETECTOR (default: with --actors or actors in the world file)")] = None,
    obstacle_sensor: Annotated[str, typer.Option("--obstacle-sensor", help="What sees obstacles: laser (the ERIM) or fido (FIDO's stereo) — CODGER's OBSTACLE DETECTOR, EDDIE's obstacle stop (issue 41)")] = "laser",
    map_file: Annotated[Optional[Path], typer.Option("--map", help="Map file the robot gets (e.g. from `sidewalk mapbuild`)")] = None,
    # ---- issue 10: faults and the speed cap ----
    fault: Annotated[Optional[list[str]], typer.Option("--fault", help="Inject a fault NAME@T (T: sim seconds after submission): kill-central, kill-service, kill-perception, wedge-driver, wedge-planner, position-jump; repeatable")] = None,
    max_speed: Annotated[Optional[float], typer.Option("--max-speed", help="Cap the speed (m/s): CODGER the PILOT's for every segment, EDDIE the route's and the controller's")] = None,
    # ---- issue 13: road following as the Navlab did it ----
    road_method: Annotated[str, typer.Option("--road-method", help="How the road is found: perception (colored-range segmentation), scarf, yarf or alvinn — PERCEPTION's method (codger), vision road following's (eddie)")] = "perception",
    alvinn_weights: Annotated[Optional[Path], typer.Option("--alvinn-weights", help="ALVINN's weights (.npz from `sidewalk roadfollow train`), needed with --road-method alvinn")] = None,
    vision_workers: Annotated[int, typer.Option("--vision-workers", help="Processes the vision of PERCEPTION (codger) or of vision road following (eddie) runs on, in stripes (issue 41; 1: the module's own process)")] = 1,
    lockstep: Annotated[bool, typer.Option("--lockstep/--realtime", help="Lock-step: the simulator steps only once every module handled its inputs (reproducible; --rtf unused), or real time at --rtf (latency under load is part of the result)")] = False,
) -> None:
    """Run a mission as OS processes on loopback Zenoh (CODGER: blackboard and modules; --arch eddie: EDDIE, no blackboard); writes run.mcap."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress as RichProgress, TextColumn, TimeElapsedColumn

    from pydantic import ValidationError

    from sidewalk.launcher import LaunchError, Progress, RunConfig, preflight, run_mission

    if vehicle is not None and vehicle not in ("terregator", "navlab"):
        raise typer.BadParameter(f"{vehicle!r} is not terregator or navlab", param_hint="--vehicle")
    if arch not in ("codger", "eddie"):
        raise typer.BadParameter(f"{arch!r} is not codger or eddie", param_hint="--arch")
    if not 0 < monitor_port < 65536:  # issue 11
        raise typer.BadParameter(f"must be 1-65535, got {monitor_port}", param_hint="--monitor-port")
    pe_m, pe_deg = _parse_pose_error(pose_error)
    if map_error is not None and not (math.isfinite(map_error) and map_error >= 0):
        raise typer.BadParameter(f"{map_error!r} is not a distance >= 0 [m]", param_hint="--map-error")
    from sidewalk.compare.errors import CompareError
    from sidewalk.compare.faults import parse_fault

    try:
        fault_specs = tuple(parse_fault(f) for f in fault or ())
    except CompareError as exc:
        raise typer.BadParameter(str(exc), param_hint="--fault") from None
    if obstacle_sensor not in ("laser", "fido"):  # issue 41
        raise typer.BadParameter(f"{obstacle_sensor!r} is not laser or fido", param_hint="--obstacle-sensor")
    if road_method not in ("perception", "scarf", "yarf", "alvinn"):  # issue 13
        raise typer.BadParameter(f"{road_method!r} is not perception, scarf, yarf or alvinn", param_hint="--road-method")
    if max_speed is not None and not (math.isfinite(max_speed) and max_speed > 0):
        raise typer.BadParameter(f"{max_speed!r} is not a speed > 0 (m/s)", param_hint="--max-speed")
    if world is None:  # the mission names its world: `--mission amv-delivery` alone runs on north_hills
        world = _mission_world(mission) or "campus"
    try:
        cfg = RunConfig(world=world, mission=mission, vehicle=vehicle, rtf=rtf, seed=seed, out=out,
                        perception=not no_perception, pose_error_m=pe_m, pose_error_deg=pe_deg, map_error_m=map_error,
                        max_sim_time_s=max_sim_time, max_wall_time_s=max_wall_time, namespace=ns, arch=arch,
                        record=not no_record, monitor_port=monitor_port if monitor else None,  # issue 11
                        secure=secure, actors=actors, obstacles=obstacles, map_file=map_file,  # issue 12
                        obstacle_sensor=obstacle_sensor,  # issue 41
                        faults=fault_specs, max_speed=max_speed,  # issue 10
                        road_method=road_method, alvinn_weights=alvinn_weights,  # issue 13
                        vision_workers=vision_workers,  # issue 41
                        lockstep=lockstep)
    except ValidationError as exc:
        e = exc.errors()[0]
        field = str(e["loc"][0])
        flag = _FLAGS.get(field, f"--{field.replace('_', '-')}")
        raise typer.BadParameter(f"{e['input']!r}: {e['msg'].lower()}", param_hint=flag) from None
    console = Console(stderr=True)
    if secure is not None:
        from wire.network import SecureConfig

        problems = SecureConfig(dir=secure, role="evaluation").problems(("127.0.0.1",))
        if problems:
            raise typer.BadParameter(problems[0].removeprefix("--secure: "), param_hint="--secure")
    try:
        preflight(cfg)
    except LaunchError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    url = _monitor_preflight(cfg, console)  # issue 11: the monitor's port, checked before anything starts
    with RichProgress(
        TextColumn("[bold]{task.fields[step]}"),
        BarColumn(),
        TextColumn("step {task.completed:.0f}/{task.total:.0f}"),
        TextColumn("{task.fields[dist]:7.1f} m"),
        TextColumn("sim {task.fields[sim]:7.1f} s"),
        TextColumn("RTF {task.fields[rtf]:5.1f}"),
        TextColumn("{task.fields[state]}"),
        TimeElapsedColumn(),
        console=console,
        transient=False,
    ) as bar:
        task = bar.add_task("run", total=1, step="starting", dist=0.0, sim=0.0, rtf=0.0, state="starting")

        announced = []
        url_shown: list[bool] = []

        def show(p: Progress) -> None:
            if url and not url_shown and p.step not in _BEFORE_MONITOR:  # issue 11: the page is up now
                url_shown.append(True)
                bar.console.print(f"monitor: [bold]{url}[/bold]")
            if not announced:
                announced.append(True)
                bar.console.print(f"namespace [bold]{p.namespace}[/bold], endpoint [bold]{p.endpoint}[/bold] — inspect with "
                                  f"`sidewalk status --ns {p.namespace} --connect {p.endpoint}"
                                  f"{'' if secure is None else f' --secure {secure}'}`")
            bar.update(task, total=max(1, p.step_count), completed=p.step_index, step=p.step[:28], dist=p.distance_m,
                       sim=p.sim_time_s, rtf=p.rtf, state=p.state)

        try:
            report = asyncio.run(run_mission(cfg, show))
        except LaunchError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(2) from None
        except KeyboardInterrupt:
            console.print("[yellow]interrupted: every process was stopped[/yellow]")
            raise typer.Exit(130) from None
        bar.update(task, completed=len([s for s in report.steps if s.success]))
    verdict = "[green]success[/green]" if report.success else "[red]failed[/red]"
    claim = "claimed success" if report.claimed_success else "claimed failure"
    goal = "-" if report.goal_error_m is None else f"{report.goal_error_m:.2f} m"
    console.print(
        f"{report.mission}: {verdict} by truth ({claim}) — goal error {goal}; {report.distance_m:.1f} m in "
        f"{report.sim_time_s:.1f} s sim ({report.wall_time_s:.1f} s wall, RTF {report.rtf_achieved:.1f}); "
        f"collisions {report.collisions}; position error final {report.position_error_m.final}; report: {out / 'report.json'}"
    )
    if report.reason:
        console.print(f"  {report.reason}")
    raise typer.Exit(0 if report.success else 1)


def up(ctx: typer.Context, module: Annotated[str, typer.Argument(help="router, blackboard, sim, captain, map_navigator, pilot, helm, perception; EDDIE: controller, navigator, map_manager, mission_service, road_following, landmark_matching, obstacle_stop; FIDO: fido_obstacles (CODGER), fido_stop (EDDIE)")]) -> None:
    """Run one part of the system on this host; the rest of the arguments go to it (try `up pilot --help`)."""
    name = module.replace("-", "_")
    argv = list(ctx.args)
    if name in ("router", "blackboard", "sim"):
        from typer.main import get_command

        sub = importlib.import_module(f"sidewalk.cli._{name}")
        cmd = get_command(getattr(sub, f"{name}_app"))
        # a Typer app with a single command collapses into that command
        args = ["serve", *argv] if hasattr(cmd, "commands") else argv
        # errors go up to the one-line handler of `sidewalk`'s main
        rv = cmd.main(args=args, prog_name=f"sidewalk up {name}", standalone_mode=False)
        raise typer.Exit(rv if isinstance(rv, int) else 0)
    if name not in UP_TARGETS:
        known = ", ".join(["router", "blackboard", "sim", *UP_TARGETS])
        raise typer.BadParameter(f"unknown module {module!r}; known: {known}", param_hint="MODULE")
    modname = f"{UP_TARGETS[name]}.__main__"
    try:
        target = importlib.import_module(modname)
    except ModuleNotFoundError as exc:
        if not modname.startswith(exc.name or "\0"):
            raise
        raise typer.BadParameter(f"module {module!r} is not part of this installation ({modname} is missing)", param_hint="MODULE") from None
    main: Callable[[list[str]], int] = target.main
    raise typer.Exit(main(argv) or 0)


@with_network()
def submit(
    file: Annotated[Path, typer.Argument(help="Mission file (YAML or JSON), or a mission name from worlds/")],
    follow: Annotated[bool, typer.Option("--follow/--no-follow", help="Follow the mission until it ends")] = True,
    timeout: Annotated[float, typer.Option(help="Seconds to wait for the CAPTAIN to answer")] = 10.0,
    net: NetworkConfig = None,  # type: ignore[assignment]
) -> None:
    """Send a mission to the CAPTAIN over Zenoh and follow its progress."""
    from modules.captain.missionfile import MissionFileError, load_mission
    from sidewalk.missions import mission_path

    try:
        path = mission_path(file)
        load_mission(path)  # checked here first: a bad or huge file is named and never sent
        text = path.read_text()
    except (FileNotFoundError, OSError) as exc:
        raise typer.BadParameter(str(exc), param_hint="FILE") from None
    except MissionFileError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    raise typer.Exit(asyncio.run(_submit(net, text, follow, timeout)))


async def _submit(net: NetworkConfig, text: str, follow: bool, timeout: float) -> int:
    from rich.console import Console

    from sidewalk.mission_client import MissionClient, MissionRejected, MissionServiceUnavailable
    from wire.aio import Link
    from wire.keys import ModuleKeys

    console = Console()
    link = Link.open(net)
    try:
        client = MissionClient(link, ModuleKeys(net.namespace), timeout=timeout)
        try:
            acc = await client.submit(text)
        except MissionRejected as exc:
            console.print(f"[red]rejected:[/red] {exc.rejection.message}")
            return 2
        except MissionServiceUnavailable as exc:
            typer.echo(f"error: {exc}", err=True)
            return 3
        console.print(f"mission accepted: [bold]{acc.mission_id}[/bold]")
        if not follow:
            return 0
        last = None
        while True:
            st = await client.status(acc.mission_id)
            line = (st.state, st.current_step)
            if line != last:
                step = st.steps[st.current_step].name if st.current_step is not None and st.steps else "-"
                console.print(f"  {st.state:<10} step {(st.current_step or 0) + 1}/{st.step_count} {step} {st.reason}")
                last = line
            if st.terminal:
                for s in st.steps:
                    console.print(f"    {s.name:<24} {s.state:<10} {s.reason}")
                return 0 if st.state == "succeeded" else 1
            await asyncio.sleep(0.5)  # polling a remote status for a person to read
    finally:
        link.close()


@with_network()
def status(
    timeout: Annotated[float, typer.Option(help="Seconds to wait for answers")] = 2.0,
    heartbeat_wait: Annotated[float, typer.Option(help="Seconds to listen for heartbeats: a live module silent that long is reported wedged (0: skip)")] = 3.0,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object instead of tables")] = False,
    net: NetworkConfig = None,  # type: ignore[assignment]
) -> None:
    """List the live modules (liveliness, heartbeat age, wedged ones) and the missions the CAPTAIN knows."""
    if timeout <= 0 or heartbeat_wait < 0:
        raise typer.BadParameter("--timeout must be > 0 and --heartbeat-wait ≥ 0 [s]")
    raise typer.Exit(asyncio.run(_status(net, timeout, heartbeat_wait, as_json)))


async def _status(net: NetworkConfig, timeout: float, heartbeat_wait: float, as_json: bool) -> int:
    from sidewalk.json_out import dumps
    import time as _time

    from wire.aio import Link
    from wire.keys import ModuleKeys

    keys = ModuleKeys(net.namespace)
    link = Link.open(net)
    try:
        alive = await link.alive_keys(keys.alive_everything, timeout=timeout)
        names = sorted(k.rsplit("/", 1)[-1] for k in alive if "/bbclient/" not in k)
        clients = sum(1 for k in alive if "/bbclient/" in k)
        health: list = []
        sts: list = []
        if names:
            from sidewalk.health import ModuleHealth, collect_heartbeats

            beats = await collect_heartbeats(link, keys, set(names), heartbeat_wait) if heartbeat_wait > 0 else {}
            now = _time.time()
            health = [ModuleHealth.judge(n, beats.get(n), now, listened_s=heartbeat_wait) for n in names]
            try:
                answers = [r for r in await link.get(keys.mission_status("*"), timeout=timeout) if r.ok]
                if answers:  # the mission models (numpy, pydantic) only when a mission service answered
                    from modules.vocabulary import MissionStatus

                    sts = [MissionStatus.model_validate_json(r.payload) for r in answers]
            except Exception:  # no CAPTAIN: nothing more to show
                sts = []
        wedged = [h.name for h in health if h.state == "wedged"]
        no_node = [h.name for h in health if h.state == "no-node"]
        if as_json:
            print(dumps({
                "namespace": net.namespace, "modules": [h.model_dump(mode="json") for h in health],
                "blackboard_clients": clients, "wedged": wedged, "no_node": no_node,
                "missions": [s.model_dump(mode="json") for s in sts],
            }))
        else:
            from rich.console import Console
            from rich.table import Table

            console = Console()
            table = Table("module", "state", "heartbeat age [s]", "blackboard", "monitors", "host", "pid",
                          title=f"live in namespace {net.namespace!r}")
            for h in health:
                age = "-" if h.heartbeat_age_s is None else f"{h.heartbeat_age_s:.1f}"
                style = "red" if h.state in ("wedged", "no-node") else "yellow" if h.state == "resyncing" else ""
                bbl = h.blackboard or "-"
                if h.resyncs:
                    bbl += f" ({h.resyncs} resync{'s' if h.resyncs > 1 else ''})"
                table.add_row(h.name, f"[{style}]{h.state}[/{style}]" if style else h.state, age, bbl,
                              "-" if h.monitors is None else str(h.monitors), h.host or "-", str(h.pid or "-"))
            console.print(table)
            if clients:
                console.print(f"{clients} blackboard client(s) connected")
            if not names:
                console.print("[yellow]nothing alive: is the system running, and are --connect/--ns right?[/yellow]")
            if sts:
                mt = Table("mission", "name", "state", "step", "sim [s]", "route done / left [m]", "pose x, y [m], yaw [°]",
                           "no progress for [s]", "waiting", "reason", title="missions (where each is, as the robot believes)")
                for s in sts:
                    mt.add_row(s.mission_id, s.name, s.state, f"{(s.current_step or 0) + 1}/{s.step_count}", *_progress_cells(s),
                               s.reason)
                console.print(mt)
        if not names:
            return 1
        return 4 if wedged or no_node else 0
    finally:
        link.close()


def _progress_cells(st) -> tuple[str, str, str, str, str]:  # noqa: ANN001 - a MissionStatus
    """Return a running mission's sim time, route done / left, pose, time without progress and waiting reason as table cells."""
    p = st.progress
    if p is None:
        return ("-",) * 5
    route = "-" if p.route_done_m is None else f"{p.route_done_m:.1f} / {p.route_left_m:.1f}"
    pose = "-" if p.pose is None else f"{p.pose.x:.1f}, {p.pose.y:.1f}, {math.degrees(p.pose.yaw):.0f}"
    since = "-" if p.since_progress_s is None else f"{p.since_progress_s:.1f}"
    return f"{p.sim_time_s:.1f}", route, pose, since, p.waiting or "-"


@with_network()
def cancel(
    mission_id: Annotated[str, typer.Argument(help="Mission id (from submit or status)")],
    timeout: Annotated[float, typer.Option(help="Seconds to wait for the CAPTAIN")] = 10.0,
    net: NetworkConfig = None,  # type: ignore[assignment]
) -> None:
    """Cancel a running mission."""
    raise typer.Exit(asyncio.run(_cancel(net, mission_id, timeout)))


async def _cancel(net: NetworkConfig, mission_id: str, timeout: float) -> int:
    from sidewalk.mission_client import MissionClient, MissionRejected, MissionServiceUnavailable
    from wire.aio import Link
    from wire.keys import ModuleKeys

    link = Link.open(net)
    try:
        st = await MissionClient(link, ModuleKeys(net.namespace), timeout=timeout).cancel(mission_id)
        typer.echo(f"{st.mission_id}: {st.state} {st.reason}")
        return 0
    except (MissionRejected, MissionServiceUnavailable) as exc:
        typer.echo(f"error: {exc}", err=True)
        return 2
    finally:
        link.close()


def register(app: typer.Typer) -> None:
    """Add run, up, submit, status and cancel to the top-level app."""
    app.command("run")(run)
    app.command(
        "up",
        context_settings={"allow_extra_args": True, "ignore_unknown_options": True, "help_option_names": []},
    )(up)
    app.command("submit")(submit)
    app.command("status")(status)
    app.command("cancel")(cancel)


def _mission_world(mission: str) -> str | None:
    """Return the world the mission file names (None: it names none, or it cannot be read; preflight says why)."""
    from modules.captain.missionfile import MissionFileError, load_mission
    from sidewalk.missions import mission_path

    try:
        return load_mission(mission_path(mission)).world
    except (FileNotFoundError, MissionFileError):
        return None
