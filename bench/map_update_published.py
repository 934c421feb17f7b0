"""Our semantic map update and planner call beside FILM's and HLSM's own code, on the same frames.

DESIGN.md §8 sets the map update budget "for scale" against FILM and HLSM on this CPU; this script is
that comparison made reproducible (issue #61). Their code is not in this repository: fetch it, check it
out anywhere outside the repo, and pass the checkouts with ``--film`` and ``--hlsm``. The script puts
them on ``sys.path``, runs their functions unmodified and records their commits. Without the paths, or
when their modules do not import, it prints one line saying why and exits 0 (CI has no internet).

Frames: ``bench.map_update``'s scripted walk through the seed-0 kitchen, rendered by our renderer with
oracle depth and segmentation, once through ALFRED's camera (300x300, 60°) and once through TEACh's
field of view at 300x300 (90°). Every frame is turned, untimed, into each system's own input:

- ours: ``OraclePerception.perceive`` -> ``Percept``; timed ``SemanticMap.update(percept, pose)``.
- FILM (``models/sem_mapping.py``, ``Semantic_Mapping.forward``, as ``main.py`` calls it): FILM's env
  preprocessing, done here: depth in centimetres with misses at FILM's 100 m sentinel, depth and the
  per-class 0/1 masks subsampled 300 -> 150 (``ds//2::ds``, FILM's ``_preprocess_obs``), one channel per
  class in ``reset_total_cat_new``'s layout (Knife, SinkBasin, the 23 other large objects, the task's
  objects, "None"), the pose as FILM's relative pose change (forward, left, radians) and the camera
  horizon through ``set_view_angles``. FILM's ALFRED arguments (``arguments.py`` with ``--alfred 1``, one
  process): 150x150 frames, 5 cm cells, a 12 m map. Three configurations, all fed the same oracle depth:
  as published (``--learned_depth --use_sem_policy``: 31 categories, mapping thresholds map_pred 65 and
  cat_pred 10, which add a pruning pass), ground-truth depth (31 categories, thresholds 1 and 5) and
  ground-truth depth without the semantic policy (8 categories).
- HLSM (``HlsmObservationFunction.forward``: point cloud, voxel grid, observability, equation (1)
  integration): ``AlfredObservation`` with depth in metres [1, 1, H, W], the one-hot segmentation over
  HLSM's 124 classes [1, 124, H, W] (our types by name; types HLSM lacks stay all-zero) and the float64
  world-to-camera matrix in HLSM's frame (x east, y north, z up, the start at the origin, as its
  dead-reckoning ``PoseInfo`` has it).

After its update, each of ours, FILM (ground-truth depth) and HLSM plans one step toward the fridge (its
true footprint, given to each in its own grid): ours the executor's approach step (map layers, standable
cells, ``interaction_goal_cells``, ``FmmNavigator.next_action``); FILM's ``FMMPlanner`` built,
``set_multi_goal`` and ``get_short_term_goal`` (``envs/utils/fmm_planner.py``, the calls ``_get_stg``
makes); HLSM's ``GoToSkill.act`` (value iteration network). Input preparation is untimed (see ``_film``
and ``_hlsm`` for what is left out, always in their favour).

The systems are interleaved frame by frame (the order rotates every frame) in one process with one thread
(``torch.set_num_threads(1)``, OMP/MKL/OpenBLAS threads 1); only the update and planning calls are timed.
Explored area, and the share of it that ours explored too, is recorded for each system as a check that
all were fed the same frames and poses (HLSM's 25 cm columns count as explored once any voxel is seen).

Shims, all here, none in their files: (1) packages whose ``__init__`` imports the simulator or models the
measured code never uses are registered as bare packages over their folders, so ``__init__`` is not run
(FILM's ``envs``, HLSM's ``lgp.models.alfred.hlsm``); (2) ``torchvision`` (imported by FILM's
``sem_mapping.py``, unused by ``Semantic_Mapping``), ``skimage`` (imported by ``fmm_planner.py``, used
only by ``set_goal(auto_improve=True)``) and ``moviepy.editor`` (imported by HLSM's ``lgp.utils.utils``
for GIF writing; moviepy 2 has no ``editor``) are empty stand-in modules when absent; (3) HLSM's
``lgp.paths`` demands ``LGP_*`` directories: they point at a temporary folder; (4) FILM's
``utils/distributions.py`` calls ``get_args()`` at import: it sees an empty command line. FILM's
``models/sem_mapping.py`` is loaded from its file under another module name because our repo has a
``models`` package too.

Run (their dependencies: ``pip install -e .[compare]``)::

    git clone https://github.com/soyeonm/FILM /tmp/film        # measured at e879a2c
    git clone https://github.com/valtsblukis/hlsm /tmp/hlsm    # measured at 9e30965
    .venv/bin/python -m bench.map_update_published --film /tmp/film --hlsm /tmp/hlsm

Writes ``bench/results/map_update_published.json``.
"""

from __future__ import annotations

import argparse
import gc
import importlib.util
import math
import os
import random
import sys
import tempfile
import time
import types
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np

from agent.geometry import Camera, Pose, camera_position, camera_to_world
from agent.mapping import SemanticMap
from agent.navigation.base import NavGoal, NavGrids, body_fits
from agent.navigation.fmm import FmmNavigator
from agent.navigation.goals import interaction_goal_cells
from agent.perception import Observation, OraclePerception
from bench.cli import bench_parser
from bench.map_update import render_frames, scripted_walk
from bench.stamp import THREAD_VARIABLES, BenchRun, head_commit
from harness.render.renderer import Frame
from harness.world.model import World
from harness.world.procedural.generate import generate_kitchen
from symbolic.thor import AGENT_RADIUS_M, ALFRED_HFOV_DEG, ALFRED_IMAGE_SIDE, TEACH_HFOV_DEG

if TYPE_CHECKING:
    import torch

COMPARE_LIBRARIES = ("kornia", "transforms3d", "imageio")
"""Their imports (``pip install -e .[compare]``), whose versions the stamp records beside ours."""
SEED = 0
DEFAULT_FRAMES = 80
FILM_FRAME_SIDE = 150
"""FILM's ALFRED frames (``arguments.py``: ``--alfred 1`` sets frame_width/height 150 from 300x300)."""
FILM_MISS_M = 100.0
"""FILM's ``_preprocess_depth`` writes 100 m where a reading is invalid."""
FILM_TASK_OBJECTS = 4
"""Task objects given their own channels after the large objects (``reset_total_cat_new``, one process)."""
PLAN_TARGET = "Fridge"
"""Every planner is given this object's true footprint as its goal, each in its own grid."""
FILM_GOAL_REACH_M = 0.5
"""FILM's goal map is the target's cells grown by this much: FILM's goal is the object's own cells, which
its dilated obstacles enclose, and ``_get_stg`` then grows the goal (one FMM per step of growth) until the
planner is no longer broken; starting from the grown goal runs one FMM, in FILM's favour."""
FILM_PLANNER = argparse.Namespace(
    visualize=0, save_pictures=False, stop_cond=0.55, step_size=5, obstacle_selem=4
)
"""The ``FMMPlanner`` arguments FILM's ALFRED run uses (``arguments.py`` defaults and overrides)."""
Box = tuple[float, float, float, float]


@dataclass(frozen=True)
class Checkouts:
    film: Path
    hlsm: Path


def main(argv: Sequence[str] | None = None) -> int:
    parser = bench_parser("map_update_published", __doc__)
    parser.add_argument("--film", type=Path, help="a checkout of github.com/soyeonm/FILM")
    parser.add_argument("--hlsm", type=Path, help="a checkout of github.com/valtsblukis/hlsm")
    parser.add_argument("--frames", type=int, default=DEFAULT_FRAMES, help="frames per camera")
    args = parser.parse_args(argv)
    if args.film is None or args.hlsm is None:
        print("map_update_published: skipped: needs --film PATH --hlsm PATH (checkouts of FILM and HLSM)")
        return 0
    _pin_threads(sys.argv[1:] if argv is None else list(argv))
    run = BenchRun.start("map_update_published", argv)
    checkouts = Checkouts(args.film.resolve(), args.hlsm.resolve())
    try:
        film, hlsm = _import_film(checkouts.film), _import_hlsm(checkouts.hlsm)
    except Exception as error:  # any import failure of their code means: cannot compare here
        print(f"map_update_published: skipped: their code does not import ({type(error).__name__}: {error})")
        return 0
    return _run(run, args, checkouts, film, hlsm)


# ----- their code ----------------------------------------------------------------------------------------
def _pin_threads(argv: list[str]) -> None:
    """One thread everywhere: BLAS/OpenMP pools are sized at import, so re-run the process with the
    variables set when they are not (before numpy or torch is imported), then pin torch's own pools."""
    if any(os.environ.get(name) != "1" for name in THREAD_VARIABLES):
        os.environ.update({name: "1" for name in THREAD_VARIABLES})
        os.execv(sys.executable, [sys.executable, "-m", "bench.map_update_published", *argv])
    import torch  # here, not at module top: --help and the skip line load no torch

    torch.set_num_threads(1)
    torch.set_num_interop_threads(1)


def _bare_package(name: str, folder: Path) -> None:
    """Register ``name`` as a package over ``folder`` without running its ``__init__`` (shim 1)."""
    module = types.ModuleType(name)
    module.__path__ = [str(folder)]
    sys.modules[name] = module


def _stand_in(name: str) -> None:
    """An empty module for an import the measured code never uses, when it is not installed (shim 2)."""
    if importlib.util.find_spec(name.split(".")[0]) is not None:
        try:
            __import__(name)
            return
        except ImportError:
            pass
    parts = name.split(".")
    for depth in range(1, len(parts) + 1):
        sys.modules.setdefault(".".join(parts[:depth]), types.ModuleType(".".join(parts[:depth])))


def _import_film(root: Path) -> types.SimpleNamespace:
    """FILM's ``models/sem_mapping.py`` as module ``film_sem_mapping`` (it imports ``utils``, ``envs``) and
    ``envs/utils/fmm_planner.py``."""
    sys.path.insert(0, str(root))
    _bare_package("envs", root / "envs")  # envs/__init__.py imports the ALFRED agent and THOR
    _stand_in("torchvision.models")
    _stand_in("skimage")  # fmm_planner: only _find_nearest_goal (set_goal(auto_improve=True)) calls it
    spec = importlib.util.spec_from_file_location("film_sem_mapping", root / "models" / "sem_mapping.py")
    assert spec is not None and spec.loader is not None, f"no models/sem_mapping.py under {root}"
    module = importlib.util.module_from_spec(spec)
    argv, sys.argv = sys.argv, sys.argv[:1]  # shim 4: utils/distributions.py parses the command line
    try:
        spec.loader.exec_module(module)
    finally:
        sys.argv = argv
    # Their modules are imported by name from the checkout on sys.path: FILM and HLSM are no dependency of
    # this project (nothing installs them), so no import statement names them.
    fmm_planner = importlib.import_module("envs.utils.fmm_planner")

    for name in ("utils.model", "envs.utils.depth_utils", "envs.utils.fmm_planner"):
        origin = Path(sys.modules[name].__file__ or "")
        assert origin.is_relative_to(root), f"{name} came from {origin}, not FILM's {root}"
    return types.SimpleNamespace(Semantic_Mapping=module.Semantic_Mapping, FMMPlanner=fmm_planner.FMMPlanner)


def _import_hlsm(root: Path) -> types.SimpleNamespace:
    sys.path.insert(0, str(root))
    workspace = tempfile.mkdtemp(prefix="hlsm_ws_")  # shim 3: lgp.paths refuses to import without these
    for name in ("LGP_WS_DIR", "LGP_MODEL_DIR", "LGP_DATA_DIR"):
        os.environ.setdefault(name, workspace)
    _bare_package("lgp.models.alfred.hlsm", root / "lgp" / "models" / "alfred" / "hlsm")  # __init__: models
    _stand_in("moviepy.editor")
    segmentation_definitions = importlib.import_module("lgp.env.alfred.segmentation_definitions")
    observation = importlib.import_module("lgp.env.alfred.alfred_observation")
    go_to = importlib.import_module("lgp.models.alfred.handcoded_skills.go_to")
    observation_function = importlib.import_module("lgp.models.alfred.hlsm.hlsm_observation_function")
    parameters = importlib.import_module("lgp.parameters")

    origin = Path(sys.modules["lgp"].__file__ or next(iter(sys.modules["lgp"].__path__)))
    assert origin.is_relative_to(root), f"lgp came from {origin}, not HLSM's {root}"
    return types.SimpleNamespace(
        AlfredObservation=observation.AlfredObservation,
        HlsmObservationFunction=observation_function.HlsmObservationFunction,
        GoToSkill=go_to.GoToSkill,
        Hyperparams=parameters.Hyperparams,
        segdef=segmentation_definitions,
    )


def _film_large_objects(root: Path) -> list[str]:
    """``alfred_utils/gen/constants.py``'s ``map_save_large_objects``, read from their checkout."""
    spec = importlib.util.spec_from_file_location(
        "film_constants", root / "alfred_utils" / "gen" / "constants.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return list(module.map_save_large_objects)


# ----- the run -------------------------------------------------------------------------------------------
def _run(
    run: BenchRun, args: argparse.Namespace, checkouts: Checkouts, film: types.SimpleNamespace, hlsm: Any
) -> int:
    world = generate_kitchen(SEED)
    large = _film_large_objects(checkouts.film)
    cameras = {
        "alfred_300x300_hfov60": Camera(ALFRED_IMAGE_SIDE, ALFRED_IMAGE_SIDE, ALFRED_HFOV_DEG),
        "teach_fov_300x300_hfov90": Camera(ALFRED_IMAGE_SIDE, ALFRED_IMAGE_SIDE, TEACH_HFOV_DEG),
    }
    runs: dict[str, object] = {}
    summary: dict[str, object] = {}
    for name, camera in cameras.items():
        poses = scripted_walk(world.copy(), args.frames, random.Random(SEED))
        frames = render_frames(world.copy(), camera, poses)
        systems = _systems(camera, poses[0], film, hlsm, large, world)
        report = _interleave(systems, poses, frames)
        runs[name] = {"frames": len(frames), "systems": report}
        summary[name] = _summary(report)
        medians = ", ".join(f"{n} {r['update_median_ms']} ms" for n, r in report.items())
        print(f"map_update_published: {name}: {medians}", flush=True)
    results = {
        "what": "map update and one planning step per frame, ours vs FILM's Semantic_Mapping.forward and "
        "FMMPlanner vs HLSM's HlsmObservationFunction.forward and GoToSkill.act; same frames, "
        "interleaved, one thread",
        "their_commits": {"film": head_commit(checkouts.film), "hlsm": head_commit(checkouts.hlsm)},
        "seed": SEED,
        "frames_per_camera": args.frames,
        "film_config": vars(_film_args(cameras["alfred_300x300_hfov60"], 10.0, 65.0, 31)),
        "summary": summary,
        "runs": runs,
        "shims": [
            "FILM envs and HLSM lgp.models.alfred.hlsm registered as bare packages (their __init__ imports "
            "the simulator and learned models, unused by the measured functions)",
            "torchvision.models, skimage and moviepy.editor stand-ins when absent (imported, not used)",
            "LGP_WS_DIR/LGP_MODEL_DIR/LGP_DATA_DIR set to a temporary folder",
            "sys.argv emptied while FILM imports (utils/distributions.py runs get_args() at import)",
            "FILM's models/sem_mapping.py loaded as film_sem_mapping (our repo has a models package)",
        ],
    }
    run.write(args.out, results, libraries=COMPARE_LIBRARIES)
    return 0


@dataclass
class System:
    """One map under test: ``prepare`` builds its input from a frame (untimed), ``update`` is timed."""

    name: str
    prepare: Callable[[Pose, Frame], Any]  # -> the system's own input
    update: Callable[[Any], None]
    explored: Callable[[], tuple[np.ndarray, float]]  # world (x, z) [N, 2] of explored cells, cell metres
    state_bytes: Callable[[], int]
    note: str
    plan: Callable[[Pose], Callable[[], object]] | None = None
    """Untimed: build the planner's inputs for this pose on the current map; the returned call is timed."""
    plan_note: str = ""


def _systems(
    camera: Camera, start: Pose, film: types.SimpleNamespace, hlsm: Any, large: list[str], world: World
) -> list[System]:
    """Ours, FILM in three configurations, HLSM; each with its own map starting at ``start``. Ours, FILM
    with ground-truth depth and HLSM also plan toward ``PLAN_TARGET`` after every update."""
    small = sorted({o.object_type for o in world.objects.values()} - set(large) - {"Knife", "SinkBasin"})
    target = next(o for o in world.objects.values() if o.object_type == PLAN_TARGET)
    box = (
        target.center[0] - target.size[0] / 2,
        target.center[0] + target.size[0] / 2,
        target.center[2] - target.size[2] / 2,
        target.center[2] + target.size[2] / 2,
    )
    return [
        _ours(camera, start, box),
        _film(camera, start, film, "film_learned_depth", 10.0, 65.0, large, small, None),
        _film(camera, start, film, "film_gt_depth", 5.0, 1.0, large, small, box),
        _film(camera, start, film, "film_gt_depth_no_sem_policy", 5.0, 1.0, [], small, None),
        _hlsm(camera, start, hlsm, box),
    ]


def _in_box(x: np.ndarray, z: np.ndarray, box: Box) -> np.ndarray:
    """bool mask of the world points (x, z) inside the footprint ``box`` (x0, x1, z0, z1) metres."""
    return (x >= box[0]) & (x <= box[1]) & (z >= box[2]) & (z <= box[3])


def _ours(camera: Camera, start: Pose, box: Box) -> System:
    oracle = OraclePerception(camera)
    semantic_map = SemanticMap(camera, start)
    navigator = FmmNavigator()

    def prepare(pose: Pose, frame: Frame) -> Any:
        obs = Observation(depth=frame.depth, instances=frame.instances, legend=frame.legend, pose=pose)
        return oracle.perceive(obs, target_type=None), pose

    def update(inputs: Any) -> None:
        percept, pose = inputs
        semantic_map.update(percept, pose)

    def explored() -> tuple[np.ndarray, float]:
        i, j = np.nonzero(semantic_map.explored())
        frame = semantic_map.frame
        xz = np.stack(
            [frame.origin_x + (i + 0.5) * frame.cell_m, frame.origin_z + (j + 0.5) * frame.cell_m], 1
        )
        return xz, frame.cell_m

    def plan(pose: Pose) -> Callable[[], object]:
        """What the executor's approach does each step (``agent/executor/approach.py``, ``mapview.grids``):
        map layers, standable cells, interaction goal cells, then the FMM navigator's next action."""
        frame = semantic_map.frame
        X, Z = frame.shape
        xs = frame.origin_x + (np.arange(X) + 0.5) * frame.cell_m
        zs = frame.origin_z + (np.arange(Z) + 0.5) * frame.cell_m
        target = _in_box(xs[:, None], zs[None, :], box)  # [X, Z]

        def call() -> object:
            obstacles, collisions = semantic_map.obstacles(), semantic_map.collisions()
            grids = NavGrids(obstacles, semantic_map.explored() | semantic_map.visited(), collisions)
            standable = body_fits(obstacles | collisions, frame.cell_m, AGENT_RADIUS_M)
            goal = interaction_goal_cells(target, standable, frame, hfov_deg=camera.hfov_deg)
            return navigator.next_action(grids, frame, pose, NavGoal(goal, face=target))

        return call

    return System(
        "ours",
        prepare,
        update,
        explored,
        lambda: semantic_map.nbytes,
        "SemanticMap.update at 300x300, 5 cm cells, uint8 voxels",
        plan,
        "map layers + body_fits + interaction_goal_cells + FmmNavigator.next_action on the 5 cm map",
    )


def _film_args(
    camera: Camera, cat_threshold: float, map_threshold: float, categories: int
) -> argparse.Namespace:
    """The fields ``Semantic_Mapping.__init__`` reads, as FILM's ``get_args`` sets them for ALFRED with one
    process: ``num_sem_categories`` = 1 + 1 + 1 + 5, plus 23 with the semantic policy."""
    return argparse.Namespace(
        device="cpu",
        frame_height=FILM_FRAME_SIDE,
        frame_width=FILM_FRAME_SIDE,
        map_resolution=5,
        map_size_cm=1200,
        global_downscaling=1,
        vision_range=100,
        hfov=camera.hfov_deg,
        du_scale=1,
        print_time=0,
        cat_pred_threshold=cat_threshold,
        exp_pred_threshold=1.0,
        map_pred_threshold=map_threshold,
        num_sem_categories=categories,
        no_straight_obs=True,
        num_processes=1,
        camera_height=camera.height_m,
    )


def _film(
    camera: Camera,
    start: Pose,
    film: types.SimpleNamespace,
    name: str,
    cat_threshold: float,
    map_threshold: float,
    large: list[str],
    small: list[str],
    box: Box | None,
) -> System:
    """FILM's mapping; with ``box``, also FILM's FMM planner toward it (the core of ``_get_stg``)."""
    import torch

    args = _film_args(camera, cat_threshold, map_threshold, 31 if large else 8)
    C = args.num_sem_categories
    channels = _film_channels(large, small, C)
    module = film.Semantic_Mapping(args)
    module.eval()
    cells = args.map_size_cm // args.map_resolution
    local_map = torch.zeros(1, C + 4, cells, cells)  # main.py: nc = num_sem_categories + 4
    local_pose = torch.tensor([[args.map_size_cm / 200.0, args.map_size_cm / 200.0, 0.0]])  # centre, 0°
    state: dict[str, Any] = {"map": local_map, "pose": local_pose, "last": _film_pose(start, start)}
    ds = camera.width // FILM_FRAME_SIDE

    def prepare(pose: Pose, frame: Frame) -> Any:
        depth = np.where(frame.depth > 0, frame.depth, FILM_MISS_M)[ds // 2 :: ds, ds // 2 :: ds] * 100.0
        obs = np.zeros((1, 4 + C, FILM_FRAME_SIDE, FILM_FRAME_SIDE), dtype=np.float32)  # rgb unused: zeros
        obs[0, 3] = depth
        instances = frame.instances[ds // 2 :: ds, ds // 2 :: ds]
        for instance_id, object_type in frame.legend.items():
            channel = channels.get(object_type)
            if channel is not None:
                obs[0, 4 + channel] += instances == instance_id
        now = _film_pose(pose, start)
        change = torch.tensor([_film_pose_change(state["last"], now)], dtype=torch.float32)
        state["last"] = now
        module.set_view_angles([pose.horizon])
        return torch.from_numpy(obs), change

    def update(inputs: Any) -> None:
        obs, change = inputs
        _, state["map"], _, state["pose"] = module(obs, change, state["map"], state["pose"])

    cell = args.map_resolution / 100.0
    half = args.map_size_cm / 200.0

    def to_world(rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Our world (x, z) of FILM map cells: row = y, column = x (main.py's loc_r, loc_c)."""
        x, y = (cols + 0.5) * cell - half, (rows + 0.5) * cell - half  # FILM metres, the start at 0
        yaw0 = math.radians(start.yaw)
        ax, ay = math.cos(yaw0) * x + math.sin(yaw0) * y, -math.sin(yaw0) * x + math.cos(yaw0) * y
        return start.x - ay, start.z + ax

    def explored() -> tuple[np.ndarray, float]:
        """Explored cells (channel 1) back in our world."""
        rows, cols = np.nonzero(state["map"][0, 1].numpy() > 0.5)
        return np.stack(to_world(rows, cols), 1), cell

    rows, cols = np.indices((cells, cells))
    target = _in_box(*to_world(rows, cols), box) if box is not None else None  # [rows, cols]
    goal = None
    if (
        target is not None
    ):  # the cells within FILM_GOAL_REACH_M of the target, with add_boundary's zero border
        side = 2 * round(FILM_GOAL_REACH_M / cell) + 1
        disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (side, side))
        goal = np.pad(cv2.dilate(target.astype(np.uint8), disk), 1).astype(np.float64)
    square = np.ones((FILM_PLANNER.obstacle_selem,) * 2, np.uint8)  # skimage.morphology.square(4)
    cross = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))  # skimage.morphology.disk(1)

    def plan(pose: Pose) -> Callable[[], object]:
        """FILM's planner inputs as ``_plan``/``_get_stg`` make them, untimed: the rounded obstacle channel
        dilated by a 4x4 square, the agent's 3x3 cells freed, a blocked border, a cross dilation; the goal
        map with a zero border; the start cell (row, col) + 1. Timed: ``FMMPlanner`` built on it,
        ``set_multi_goal`` and ``get_short_term_goal``, the calls ``_get_stg`` makes when the plan is not
        broken (its goal bookkeeping and the two dilations are left out, in FILM's favour)."""
        grid = (np.rint(state["map"][0, 0].numpy()) > 0).astype(np.uint8)
        x, y, _ = state["pose"][0].tolist()
        r, c = int(y * 100.0 / args.map_resolution), int(x * 100.0 / args.map_resolution)
        traversible = cv2.dilate(grid, square) == 0
        traversible[r - 1 : r + 2, c - 1 : c + 2] = True
        traversible = np.pad(traversible, 1, constant_values=True)
        traversible = cv2.dilate((~traversible).astype(np.uint8), cross) == 0

        def call() -> object:
            planner = film.FMMPlanner(traversible * 1.0, FILM_PLANNER, step_size=FILM_PLANNER.step_size)
            planner.set_multi_goal(goal)
            return planner.get_short_term_goal([r + 1, c + 1], found_goal=1)

        return call

    return System(
        name,
        prepare,
        update,
        explored,
        lambda: int(state["map"].nbytes),
        f"Semantic_Mapping.forward at {FILM_FRAME_SIDE}x{FILM_FRAME_SIDE} (FILM's ALFRED frames), "
        f"{C} categories, cat_pred_threshold {cat_threshold}, map_pred_threshold {map_threshold}; "
        "state counts "
        "local_map only (main.py also keeps a full_map of the same size)",
        plan if box is not None else None,
        "FMMPlanner(traversible) + set_multi_goal + get_short_term_goal on the 12 m, 5 cm map",
    )


def _film_channels(large: list[str], small: list[str], C: int) -> dict[str, int]:
    """Type -> channel in ``reset_total_cat_new``'s layout: Knife, SinkBasin, the other large objects (with
    the semantic policy: ``large`` empty without), then the task objects, "None" last."""
    order = ["Knife", "SinkBasin", *(o for o in large if o != "SinkBasin")][: C - 1 - FILM_TASK_OBJECTS]
    order += small[:FILM_TASK_OBJECTS]
    assert len(order) <= C - 1, f"{len(order)} FILM channels for {C} categories"
    return {object_type: index for index, object_type in enumerate(order)}


def _film_pose(pose: Pose, start: Pose) -> tuple[float, float, float]:
    """FILM's map pose (x m, y m, orientation ° counter-clockwise), the start at the origin facing 0°.

    Our yaw turns clockwise seen from above (+z towards +x), FILM's orientation counter-clockwise; FILM's
    right hand lies at orientation − 90°.
    """
    yaw0 = math.radians(start.yaw)
    ax, ay = pose.z - start.z, -(pose.x - start.x)  # a frame with x along our +z, counter-clockwise angles
    x = math.cos(yaw0) * ax - math.sin(yaw0) * ay
    y = math.sin(yaw0) * ax + math.cos(yaw0) * ay
    return x, y, start.yaw - pose.yaw


def _film_pose_change(last: tuple[float, float, float], now: tuple[float, float, float]) -> list[float]:
    """(forward m, left m, turn rad) from ``last`` to ``now``: what FILM's env reports as ``sensor_pose``,
    inverted from ``get_new_pose_batch`` (x += f cos o − l sin o, y += f sin o + l cos o, o += turn)."""
    dx, dy, o = now[0] - last[0], now[1] - last[1], math.radians(last[2])
    turn = (now[2] - last[2] + 180.0) % 360.0 - 180.0
    return [dx * math.cos(o) + dy * math.sin(o), -dx * math.sin(o) + dy * math.cos(o), math.radians(turn)]


def _hlsm(camera: Camera, start: Pose, hlsm: Any, box: Box) -> System:
    import torch

    function = hlsm.HlsmObservationFunction(hlsm.Hyperparams({}))
    skill = hlsm.GoToSkill()
    n_classes = hlsm.segdef.get_num_objects()
    class_of = {name: i for name, i in hlsm.segdef.OBJECT_STR_TO_INT.items() if i < n_classes}
    state: dict[str, Any] = {"repr": None}

    def world_to_camera(pose: Pose) -> torch.Tensor:
        """[1, 4, 4] HLSM world (our x, z, y less the start: z up) -> camera (x right, y down, z ahead)."""
        axes = camera_to_world(pose)[[0, 2, 1], :]  # [3, 3] camera axes in HLSM's world (columns)
        centre = camera_position(camera, pose)[[0, 2, 1]] - np.array([start.x, start.z, 0.0])
        matrix = np.eye(4)
        matrix[:3, :3] = axes.T
        matrix[:3, 3] = -axes.T @ centre
        return torch.from_numpy(matrix)[None]  # float64, as PoseInfo.get_pose_mat gives it

    def prepare(pose: Pose, frame: Frame) -> Any:
        H, W = frame.depth.shape
        semantic = np.zeros((1, n_classes, H, W), dtype=np.float32)
        for instance_id, object_type in frame.legend.items():
            index = class_of.get(object_type)
            if index is not None:
                semantic[0, index] += frame.instances == instance_id
        return hlsm.AlfredObservation(
            rgb_image=torch.zeros(1, 3, H, W),
            depth_image=torch.from_numpy(frame.depth)[None, None],
            semantic_image=torch.from_numpy(semantic),
            inventory_vector=torch.zeros(1, n_classes),
            pose=world_to_camera(pose),
            hfov_deg=camera.hfov_deg,
            cam_horizon_deg=[pose.horizon],
            privileged_info=None,
        )

    def update(observation: Any) -> None:
        with torch.no_grad():  # HLSM's rollouts run the observation function under no_grad
            state["repr"] = function(observation, state["repr"], None)

    def explored() -> tuple[np.ndarray, float]:
        """Columns with any observed voxel, at their centres (VoxelGrid.get_centroid_coord_grid)."""
        grid = state["repr"].obs_mask
        centres = grid.get_centroid_coord_grid()[0, :2, :, :, 0]  # [2, X, Y] HLSM x, y metres
        observed = grid.data[0, 0].amax(dim=2) > 0  # [X, Y]
        x, y = (centres[axis][observed].numpy() for axis in (0, 1))
        return np.stack([x + start.x, y + start.z], 1), float(grid.voxel_size)

    def plan(pose: Pose) -> Callable[[], object]:
        """HLSM's GoToSkill (value iteration network, then the grid action turned into a THOR action) on the
        current state. Its goal, the reward map that GoForSkill would get from its learned navigation model,
        is the ring of columns around the target's footprint, set once; the agent's position is set on the
        observation as HLSM's state tracker does (``set_agent_pos``)."""
        grid = state["repr"].data
        if skill.vin.rewardmap is None:
            centres = grid.get_centroid_coord_grid()[0, :2, :, :, 0].numpy()  # [2, X, Y] HLSM metres
            target = _in_box(centres[0] + start.x, centres[1] + start.z, box)  # [X, Y]
            ring = (cv2.dilate(target.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0) & ~target
            skill.set_goal(torch.from_numpy(ring).float()[None, None])
        position = [pose.x - start.x, pose.z - start.z, -camera.height_m]  # PoseInfo.get_agent_pos
        state["repr"].observation.set_agent_pos(torch.tensor(position))

        def call() -> object:
            with torch.no_grad():
                return skill.act(state["repr"])

        return call

    def state_bytes() -> int:
        tensors = [
            state["repr"].data.data,
            state["repr"].data.occupancy,
            state["repr"].obs_mask.data,
            state["repr"].obs_mask.occupancy,
        ]
        unique = {t.untyped_storage().data_ptr(): t.untyped_storage().nbytes() for t in tensors}
        return sum(unique.values())

    return System(
        "hlsm",
        prepare,
        update,
        explored,
        state_bytes,
        f"HlsmObservationFunction.forward at {camera.width}x{camera.height}, 25 cm voxels, "
        f"{n_classes} classes",
        plan,
        "GoToSkill.act: 2D obstacle and observability maps, VIN on 61x61, grid action -> THOR action",
    )


def _interleave(
    systems: list[System], poses: list[Pose], frames: list[Frame]
) -> dict[str, dict[str, object]]:
    """Each frame goes to every system in turn; only ``update`` is timed (perf_counter, ms)."""
    times: dict[str, list[float]] = {s.name: [] for s in systems}
    plan_times: dict[str, list[float]] = {s.name: [] for s in systems if s.plan is not None}
    for index, (pose, frame) in enumerate(zip(poses, frames, strict=True)):
        shift = index % len(systems)
        for system in systems[shift:] + systems[:shift]:  # the order rotates so no system always goes first
            inputs = system.prepare(pose, frame)
            gc.collect()
            start = time.perf_counter()
            system.update(inputs)
            times[system.name].append((time.perf_counter() - start) * 1000.0)
            del inputs
            if system.plan is not None:  # then plan on the map just updated, as an agent's step does
                call = system.plan(pose)
                gc.collect()
                start = time.perf_counter()
                call()
                plan_times[system.name].append((time.perf_counter() - start) * 1000.0)
    ours = float(np.median(times["ours"]))
    explored = {system.name: system.explored() for system in systems}
    report: dict[str, dict[str, object]] = {}
    for system in systems:
        ms = np.asarray(times[system.name])
        report[system.name] = {
            "update_median_ms": round(float(np.median(ms)), 2),
            "update_p90_ms": round(float(np.percentile(ms, 90)), 2),
            "update_mean_ms": round(float(ms.mean()), 2),
            "first_frame_ms": round(float(ms[0]), 2),
            "median_ratio_to_ours": round(float(np.median(ms)) / ours, 1),
            "state_bytes": system.state_bytes(),
            "explored_m2": round(len(explored[system.name][0]) * explored[system.name][1] ** 2, 2),
            "explored_share_also_explored_by_ours": _agreement(explored[system.name][0], explored["ours"]),
            "what": system.note,
        }
        if system.name in plan_times:
            plan = np.asarray(plan_times[system.name])
            report[system.name]["plan"] = {
                "median_ms": round(float(np.median(plan)), 2),
                "p90_ms": round(float(np.percentile(plan, 90)), 2),
                "median_ratio_to_ours": round(float(np.median(plan) / np.median(plan_times["ours"])), 1),
                "what": system.plan_note,
            }
    return report


def _summary(report: dict[str, dict[str, Any]]) -> dict[str, dict[str, float]]:
    """The headline numbers of one camera's run, one small table per quantity."""
    plans = {name: r["plan"] for name, r in report.items() if "plan" in r}
    return {
        "update_median_ms": {name: r["update_median_ms"] for name, r in report.items()},
        "update_median_ratio_to_ours": {name: r["median_ratio_to_ours"] for name, r in report.items()},
        "plan_median_ms": {name: p["median_ms"] for name, p in plans.items()},
        "plan_median_ratio_to_ours": {name: p["median_ratio_to_ours"] for name, p in plans.items()},
        "state_mb": {name: round(r["state_bytes"] / 1e6, 2) for name, r in report.items()},
    }


def _agreement(xz: np.ndarray, ours: tuple[np.ndarray, float]) -> float:
    """Share of the world points ``xz`` [N, 2] lying in a cell that ours explored (or a neighbour of one):
    a check that every system was fed the same frames and poses, not only the same number of pixels."""
    points, cell = ours
    if not len(xz) or not len(points):
        return 0.0
    lo = points.min(axis=0) - 2 * cell
    shape = tuple(((points.max(axis=0) - lo) / cell).astype(int) + 3)
    mask = np.zeros(shape, dtype=np.uint8)
    i, j = ((points - lo) / cell).astype(int).T
    mask[i, j] = 1
    mask = cv2.dilate(mask, np.ones((3, 3), np.uint8))
    i, j = np.floor((xz - lo) / cell).astype(int).T
    inside = (i >= 0) & (i < shape[0]) & (j >= 0) & (j < shape[1])
    hits = np.zeros(len(xz), dtype=bool)
    hits[inside] = mask[i[inside], j[inside]] > 0
    return round(float(hits.mean()), 3)


if __name__ == "__main__":
    sys.exit(main())
