"""What surfaces look like: per-type colours, procedural textures, visible states, shading and sensor noise.

The RGB frames exist to train and test learned perception (the JARVIS seed's Mask R-CNN and depth
networks, HLSM's U-Nets), so they must be learnable (each AI2-THOR type has a stable colour and texture,
told apart from the types it shares rooms with and nearly so from all others: ``harness.render.palette``,
since boxes cannot show shape) without being trivially decodable: each instance is tinted slightly, textures
vary with the world position of the hit point, faces are shaded by their normal, and every frame gets a random
light gain and sensor noise. States that AI2-THOR shows visually are shown too: slices have a lighter cut
colour, cooked food is darker and browner, dirty things have brown blotches, broken things cracks, filled
containers their liquid, toggled-on appliances glow.
"""

from __future__ import annotations

import colorsys
import functools
import json
import zlib
from collections.abc import Sequence
from dataclasses import dataclass
from importlib import resources
from typing import Any, cast

import numpy as np

from harness.render.palette import assign_colours, room_groups, settling_order
from harness.world.model import Liquid, WorldObject
from symbolic.ontology import load_ontology

RGB = tuple[float, float, float]
"""A colour with channels in [0, 1]."""


@dataclass(frozen=True)
class Texture:
    """A procedural pattern; amplitudes are fractions of the base brightness."""

    noise: float  # value-noise amplitude
    stripes: float  # amplitude of stripes along the face's first texture axis (wood grain, brushed metal)
    grid: float  # darkening on grid lines (tiles)
    scale_per_m: float  # pattern frequency, cycles per metre


@dataclass(frozen=True)
class Material:
    rgb: RGB
    texture: str


def _read_data() -> dict[str, Any]:
    text = resources.files("harness.render").joinpath("appearance.json").read_text(encoding="utf-8")
    return dict(json.loads(text))


def _rgb(value: Sequence[float]) -> RGB:
    r, g, b = (float(v) for v in value)
    return r, g, b


_DATA = _read_data()

TEXTURES: dict[str, Texture] = {name: Texture(**entry) for name, entry in _DATA["textures"].items()}

PALETTE: dict[str, Material] = {
    name: Material(_rgb(entry["rgb"]), entry["texture"])
    for group in _DATA["materials"].values()
    for name, entry in group.items()
}
"""Natural colours of common AI2-THOR types (``appearance.json``); other types get ``hashed_material``.
These are preferences: the colour a type is drawn with is ``type_colour`` (moved where another type would
look alike)."""

CUT_COLOURS: dict[str, RGB] = {name: _rgb(v) for name, v in _DATA["cut_colours"].items()}
"""Inside colours shown by slices (and by a cracked egg's yolk)."""

LIQUID_COLOURS: dict[Liquid, RGB] = {
    cast(Liquid, name): _rgb(v) for name, v in _DATA["liquid_colours"].items()
}

GLOW_COLOURS: dict[str, RGB] = {name: _rgb(v) for name, v in _DATA["glow_colours"].items()}
"""Emission of toggled-on objects; other toggled types glow DEFAULT_GLOW."""
DEFAULT_GLOW: RGB = _rgb(_DATA["default_glow"])

COOKED_TINT: RGB = (0.55, 0.36, 0.18)  # browned food
COOKED_MIX = 0.5  # share of COOKED_TINT in a cooked object's colour
COOKED_DARKEN = 0.75  # brightness kept by the rest
DIRT_COLOUR: RGB = (0.36, 0.24, 0.12)
DISH_MAX_BROWNNESS = 0.04
"""Things that get dirty keep (R − B) / (R + G + B) at most this (``palette.brownness``; dirt is about 0.33),
so brown stains stay the one brown thing on them, as in AI2-THOR (the agent's stain cue relies on it)."""
CRACK_COLOUR: RGB = (0.08, 0.07, 0.06)

PIECE_SUFFIXES = ("Sliced", "Cracked")
"""AI2-THOR names slices ``BreadSliced`` and a broken egg ``EggCracked``; they look like their inside."""

INSTANCE_TINT = 0.07  # largest per-channel colour deviation of one instance from its type's colour
SLICE_CUT_MIX = 0.6  # how far a sliced whole object's colour moves towards its cut colour
SLICE_GAP_PERIOD_M = 0.04  # spacing of the dark gaps between slices
SLICE_GAP_DUTY = 0.15  # fraction of each period that is gap
SLICE_GAP_SHADE = 0.6  # brightness kept in a gap
STRIPE_FREQUENCY = 2.0  # stripes per texture cell (grain is finer than the noise it wanders with)
STRIPE_WARP = 0.8  # how far the noise bends the stripes, in stripe periods
DIRT_SCALE_PER_M = 14.0  # blotch frequency
DIRT_MIX = 0.9  # opacity of a blotch: enough that a green mug's stains are as brown as a white one's
DIRT_THRESHOLD = 0.58  # noise above this is dirt
CRACK_SCALE_PER_M = 9.0
CRACK_HALF_WIDTH = 0.03  # noise band around 0.5 drawn as a crack
TOP_LIQUID_MIX = 0.85  # how much a filled closed container's top face shows its liquid


@dataclass(frozen=True)
class Lighting:
    """A fixed sun plus ambient (Lambert shading by face normal) and the per-frame noise model."""

    sun: tuple[float, float, float] = (0.35, 0.86, 0.37)  # unit direction towards the light, world frame
    ambient: float = 0.45  # brightness of a face turned away from the light
    frame_gain_sd: float = 0.08  # per-frame global brightness, standard deviation
    channel_gain_sd: float = 0.04  # per-frame colour cast, standard deviation per channel
    pixel_noise_sd: float = 0.012  # per-pixel sensor noise, standard deviation (in [0, 1] intensity)


@dataclass(frozen=True)
class Surface:
    """The appearance key of a primitive: its type, the states that change its look, and its instance."""

    object_type: str
    instance_key: str  # seeds the per-instance tint and texture offset (object id, or world name for walls)
    sliced: bool = False
    cooked: bool = False
    dirty: bool = False
    broken: bool = False
    glowing: bool = False
    liquid: Liquid | None = None  # a filled container's liquid, shown on its top face
    liquid_layer: bool = False  # this primitive is the liquid itself (inside an open-topped container)
    slice_axis: int = 0  # world axis across which a sliced whole object shows its cut lines


def surface_of(obj: WorldObject) -> Surface:
    """The look of an object body from its type and AI2-THOR states."""
    size_x, _, size_z = obj.size
    return Surface(
        object_type=obj.object_type,
        instance_key=obj.object_id,
        sliced=obj.is_sliced,
        cooked=obj.is_cooked or obj.is_boiled,
        dirty=obj.is_dirty,
        broken=obj.is_broken,
        glowing=obj.is_toggled,
        liquid=obj.liquid,
        slice_axis=0 if size_x >= size_z else 2,
    )


def base_type(object_type: str) -> str:
    """``BreadSliced`` -> ``Bread``: pieces share their whole's palette entry."""
    for suffix in PIECE_SUFFIXES:
        if object_type.endswith(suffix) and len(object_type) > len(suffix):
            return object_type[: -len(suffix)]
    return object_type


def _stable_hash(text: str) -> int:
    """A hash that is the same in every process (Python's ``hash`` of str is salted)."""
    return zlib.crc32(text.encode("utf-8"))


def hashed_material(object_type: str) -> Material:
    """A stable mid-saturation colour for types the palette does not list."""
    h = _stable_hash(object_type)
    hue = (h & 0xFFFF) / 0xFFFF
    saturation = 0.35 + 0.35 * ((h >> 16) & 0xFF) / 0xFF
    value = 0.45 + 0.40 * ((h >> 24) & 0xFF) / 0xFF
    return Material(colorsys.hsv_to_rgb(hue, saturation, value), "plain")


def material_for(object_type: str) -> Material:
    """The natural material of a type (pieces share their whole's texture)."""
    return PALETTE.get(base_type(object_type)) or hashed_material(base_type(object_type))


def natural_cut_colour(object_type: str) -> RGB:
    """The natural inside of a type: its cut colour, else its natural colour lightened halfway to cream."""
    kind = base_type(object_type)
    if kind in CUT_COLOURS:
        return CUT_COLOURS[kind]
    r, g, b = material_for(kind).rgb
    return (0.5 * r + 0.5 * 0.97, 0.5 * g + 0.5 * 0.93, 0.5 * b + 0.5 * 0.80)


def natural_colour(object_type: str) -> RGB:
    """What a type would look like if it had no room-mates to be told apart from."""
    if base_type(object_type) != object_type:
        return natural_cut_colour(object_type)
    return material_for(object_type).rgb


@functools.cache
def type_colours() -> dict[str, RGB]:
    """The drawn base colour of every ontology type (``harness.render.palette``), computed once per
    process."""
    ontology = load_ontology()
    preferred = {name: natural_colour(name) for name in ontology.types}
    groups = room_groups(ontology)
    dishes = {name: DISH_MAX_BROWNNESS for name in ontology.types if ontology.get(name).dirtyable}
    return assign_colours(preferred, groups, settling_order(preferred, groups), dishes)


def type_colour(object_type: str) -> RGB:
    """The drawn base colour of a type; names outside the ontology keep their natural colour."""
    return type_colours().get(object_type) or natural_colour(object_type)


def cut_colour(object_type: str) -> RGB:
    """The inside of a type as drawn: the colour of its pieces (``BreadSliced`` for bread), so a sliced
    loaf shows what its slices will look like."""
    kind = base_type(object_type)
    pieces = [f"{kind}{suffix}" for suffix in PIECE_SUFFIXES if f"{kind}{suffix}" in type_colours()]
    return type_colour(pieces[0]) if pieces else natural_cut_colour(object_type)


def _instance_tint(instance_key: str) -> RGB:
    """Multiplicative per-channel gains within 1 ± INSTANCE_TINT."""
    h = _stable_hash("tint:" + instance_key)
    r, g, b = (1.0 + INSTANCE_TINT * (2.0 * ((h >> shift) & 0xFF) / 255.0 - 1.0) for shift in (0, 8, 16))
    return r, g, b


def _pattern_offset(instance_key: str) -> tuple[float, float]:
    """Shifts the texture lattice per instance so neighbouring objects' patterns do not line up."""
    h = _stable_hash("offset:" + instance_key)
    return float(h & 0xFFFF) / 97.0, float(h >> 16) / 89.0


@dataclass(frozen=True)
class SurfaceTable:
    """Per-surface shading parameters as arrays, so shading is one gather per pixel (S = surfaces)."""

    colour: np.ndarray  # float32 [S, 3] base colour after tint, cooking and slicing
    noise: np.ndarray  # float32 [S]
    stripes: np.ndarray  # float32 [S]
    grid: np.ndarray  # float32 [S]
    scale: np.ndarray  # float32 [S] cycles per metre
    offset: np.ndarray  # float32 [S, 2] texture lattice offset
    sliced: np.ndarray  # bool [S] whole object showing gaps between its slices
    slice_axis: np.ndarray  # int64 [S]
    dirty: np.ndarray  # bool [S]
    broken: np.ndarray  # bool [S]
    top_liquid: np.ndarray  # float32 [S, 3] liquid colour shown on the top face
    has_top_liquid: np.ndarray  # bool [S]
    glow: np.ndarray  # float32 [S, 3]
    glowing: np.ndarray  # bool [S]


def _surface_colour(surface: Surface) -> RGB:
    if surface.liquid_layer:
        assert surface.liquid is not None, f"liquid layer of {surface.instance_key} has no liquid"
        return LIQUID_COLOURS[surface.liquid]
    return type_colour(surface.object_type)


def _blend(a: RGB, b: RGB, share_of_b: float) -> RGB:
    r, g, bl = ((1.0 - share_of_b) * x + share_of_b * y for x, y in zip(a, b, strict=True))
    return r, g, bl


def _body_colour(surface: Surface) -> RGB:
    """Base colour after the instance tint and the colour-changing states (cooked, sliced)."""
    tint = _instance_tint(surface.instance_key)
    r, g, b = (min(1.0, c * t) for c, t in zip(_surface_colour(surface), tint, strict=True))
    rgb: RGB = (r, g, b)
    if surface.cooked:
        darker = (COOKED_DARKEN * r, COOKED_DARKEN * g, COOKED_DARKEN * b)
        rgb = _blend(darker, COOKED_TINT, COOKED_MIX)
    if surface.sliced:
        rgb = _blend(rgb, cut_colour(surface.object_type), SLICE_CUT_MIX)
    return rgb


@functools.lru_cache(maxsize=4096)
def _surface_row(surface: Surface) -> tuple[float, ...]:
    """One surface's shading parameters in SurfaceTable column order (memoised: worlds reuse surfaces)."""
    texture = (
        TEXTURES["liquid"] if surface.liquid_layer else TEXTURES[material_for(surface.object_type).texture]
    )
    top_liquid = LIQUID_COLOURS[surface.liquid] if surface.liquid is not None else (0.0, 0.0, 0.0)
    return (
        *_body_colour(surface),
        texture.noise,
        texture.stripes,
        texture.grid,
        texture.scale_per_m,
        *_pattern_offset(surface.instance_key),
        *top_liquid,
        *GLOW_COLOURS.get(base_type(surface.object_type), DEFAULT_GLOW),
        float(surface.sliced),
        float(surface.slice_axis),
        float(surface.dirty),
        float(surface.broken),
        float(surface.liquid is not None and not surface.liquid_layer),
        float(surface.glowing),
    )


def compile_surfaces(surfaces: Sequence[Surface]) -> SurfaceTable:
    """Stack the parameters of the surfaces a frame draws (index = primitive index)."""
    rows = np.array([_surface_row(s) for s in surfaces], dtype=np.float32)  # [S, 21]
    return SurfaceTable(
        colour=rows[:, 0:3],
        noise=rows[:, 3],
        stripes=rows[:, 4],
        grid=rows[:, 5],
        scale=rows[:, 6],
        offset=rows[:, 7:9],
        top_liquid=rows[:, 9:12],
        glow=rows[:, 12:15],
        sliced=rows[:, 15] > 0,
        slice_axis=rows[:, 16].astype(np.int64),
        dirty=rows[:, 17] > 0,
        broken=rows[:, 18] > 0,
        has_top_liquid=rows[:, 19] > 0,
        glowing=rows[:, 20] > 0,
    )


LATTICE_SIDE = 256  # value-noise lattice period, cells (a power of two: indices wrap with a bit mask)


@functools.cache
def _noise_lattice() -> np.ndarray:
    """float32 [LATTICE_SIDE**2] of fixed uniform values, flattened; read-only, built on first use."""
    lattice = np.random.default_rng(20240607).random(LATTICE_SIDE * LATTICE_SIDE, dtype=np.float32)
    lattice.flags.writeable = False
    return lattice


def value_noise(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Smooth noise in [0, 1] at lattice coordinates (a, b): bilinear with smoothstep between cells."""
    lattice = _noise_lattice()
    mask = LATTICE_SIDE - 1
    a0 = np.floor(a)
    b0 = np.floor(b)
    fa = a - a0
    fb = b - b0
    fa = fa * fa * (3.0 - 2.0 * fa)
    fb = fb * fb * (3.0 - 2.0 * fb)
    ia = a0.astype(np.int32) & mask
    ib = b0.astype(np.int32) & mask
    row = ia * LATTICE_SIDE
    row1 = ((ia + 1) & mask) * LATTICE_SIDE
    ib1 = (ib + 1) & mask
    v00 = lattice.take(row + ib)
    v10 = lattice.take(row1 + ib)
    v01 = lattice.take(row + ib1)
    v11 = lattice.take(row1 + ib1)
    near_b = v00 + fa * (v10 - v00)
    far_b = v01 + fa * (v11 - v01)
    return near_b + fb * (far_b - near_b)


def _mix(rgb: np.ndarray, where: np.ndarray, colour: np.ndarray, amount: float) -> None:
    """In place: blend ``colour`` ([3] or [3, N]) into the columns of ``rgb`` [3, N] selected by ``where``."""
    target = colour[:, where] if colour.ndim == 2 else colour[:, None]
    rgb[:, where] = (1.0 - amount) * rgb[:, where] + amount * target


def shade(
    table: SurfaceTable,
    surface_index: np.ndarray,
    points: np.ndarray,
    normal_axis: np.ndarray,
    normal_sign: np.ndarray,
    lighting: Lighting,
) -> np.ndarray:
    """float32 [3, N] colours in [0, 1] of N hit points (channels first: each channel is contiguous).

    surface_index int [N] indexes ``table``; points float32 [3, N] are world hit points; the face normal is
    ``normal_sign`` (±1, float32 [N]) along world axis ``normal_axis`` (int [N], 0=x 1=y 2=z).
    """
    s = surface_index
    x, y, z = points
    # Texture coordinates lie in the face: (z, y) on x-faces, (x, z) on y-faces, (x, y) on z-faces.
    tex_a = np.where(normal_axis == 0, z, x)
    tex_b = np.where(normal_axis == 1, z, y)
    scale = table.scale.take(s)
    a = tex_a * scale + table.offset[:, 0].take(s)
    b = tex_b * scale + table.offset[:, 1].take(s)
    noise = value_noise(a, b)
    pattern = table.noise.take(s) * (2.0 * noise - 1.0)
    stripes = table.stripes.take(s)
    striped = stripes > 0
    if striped.any():
        grain = STRIPE_FREQUENCY * a[striped] + STRIPE_WARP * noise[striped]
        pattern[striped] += stripes[striped] * np.sin(np.float32(2 * np.pi) * grain)
    grid = table.grid.take(s)
    tiled = grid > 0
    if tiled.any():
        cell_a = a[tiled] - np.floor(a[tiled])
        cell_b = b[tiled] - np.floor(b[tiled])
        pattern[tiled] -= grid[tiled] * (np.minimum(cell_a, cell_b) < 0.04)
    pattern += 1.0
    rgb = table.colour.T.take(s, axis=1) * pattern  # [3, N]

    sliced = table.sliced.take(s)
    if sliced.any():
        along = points[table.slice_axis.take(s), np.arange(s.size)]
        gap = sliced & ((along / SLICE_GAP_PERIOD_M) % 1.0 < SLICE_GAP_DUTY)
        rgb[:, gap] *= SLICE_GAP_SHADE
    dirty = table.dirty.take(s)
    if dirty.any():
        blotch = value_noise(tex_a[dirty] * DIRT_SCALE_PER_M + 31.0, tex_b[dirty] * DIRT_SCALE_PER_M + 17.0)
        dirty[dirty] = blotch > DIRT_THRESHOLD
        _mix(rgb, dirty, np.array(DIRT_COLOUR, dtype=np.float32), DIRT_MIX)
    broken = table.broken.take(s)
    if broken.any():
        crack = value_noise(tex_a[broken] * CRACK_SCALE_PER_M + 5.0, tex_b[broken] * CRACK_SCALE_PER_M + 9.0)
        broken[broken] = np.abs(crack - 0.5) < CRACK_HALF_WIDTH
        _mix(rgb, broken, np.array(CRACK_COLOUR, dtype=np.float32), 0.9)
    top = table.has_top_liquid.take(s) & (normal_axis == 1) & (normal_sign > 0)
    if top.any():
        _mix(rgb, top, table.top_liquid.T.take(s, axis=1), TOP_LIQUID_MIX)

    sun = np.asarray(lighting.sun, dtype=np.float32)
    facing = np.maximum(normal_sign * sun.take(normal_axis), 0.0)  # Lambert: max(0, n·l)
    rgb *= lighting.ambient + (1.0 - lighting.ambient) * facing

    glowing = table.glowing.take(s)
    if glowing.any():
        emission = table.glow.T.take(s[glowing], axis=1) * (0.85 + 0.3 * noise[glowing])
        rgb[:, glowing] = 0.35 * rgb[:, glowing] + emission
    return np.clip(rgb, 0.0, 1.0, out=rgb)


class Exposure:
    """A frame's camera response: light gain and colour cast drawn once, sensor noise drawn per batch.

    Without a seed it only quantises, so tests and the expert see noise-free frames. Batches must be
    exposed in the same order every time for the noise to be reproducible.
    """

    def __init__(self, noise_seed: int | None, lighting: Lighting) -> None:
        self._rng = None if noise_seed is None else np.random.default_rng(noise_seed)
        self._pixel_sd = lighting.pixel_noise_sd
        self._gain = np.ones((3, 1), dtype=np.float32)
        if self._rng is not None:
            frame_gain = 1.0 + lighting.frame_gain_sd * self._rng.standard_normal()
            cast = 1.0 + lighting.channel_gain_sd * self._rng.standard_normal(3)
            self._gain = (frame_gain * cast).astype(np.float32)[:, None]

    def apply(self, rgb: np.ndarray) -> np.ndarray:
        """uint8 [N, 3] from linear colours float32 [3, N] in [0, 1]."""
        if self._rng is not None:
            rgb = rgb * self._gain
            # Uniform noise with the configured standard deviation: cheaper to draw than Gaussian.
            noise = self._rng.random(rgb.shape, dtype=np.float32) - 0.5
            rgb += noise * np.float32(self._pixel_sd * 12**0.5)
        return np.clip(rgb * 255.0 + 0.5, 0.0, 255.0).astype(np.uint8).T
