"""What a frame builds and draws, decided without GL: the light faces that add something (each
with the maps it needs, how its light pass finds the transmittance, and whether the media take
its light from the world field) and the passes that draw them, how they end (a lone pass that
composes its own image, or the composite pass). ``Renderer`` plans a frame with ``plan_frame``
once its media are on the GPU, then builds and draws what the plan says.

The world's light (engine/world_light.py: suns over the sphere) reaches bounded media through a
field: each world face's light arriving at the cells of the lattice over the media
(engine/diffusion.py), summed, and read by the camera's one march as light scattered evenly (the
phase function averaged over a world that lights from every side). Those faces' passes light the
surfaces alone and march no medium: the world costs its maps, the lattice's lookups and a
surface pass per face, not a march per face."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .light import LightFrame, cone_meets_box, face_meets_box, light_faces
from .passes.bindings import MEDIUM_BOX, MEDIUM_EVERYWHERE, MEDIUM_GRID, MediaGPU, MediumSlot
from .passes.scattering import LIGHT_T_ANALYTIC, LIGHT_T_MARCH, LIGHT_T_NONE, LIGHT_T_TFM, LIGHT_T_UNIT
from .passes.tfm import MIN_FOOTPRINT_RESOLUTION, tfm_resolution
from .quality import footprint_texels_per_voxel
from .scene import Light, RenderSettings, Scene

# A world face's TFM side where the world field carries its light: the field resolves no finer
# than the lattice's cells (diffusion.MAX_SIDE = 48 a side over the media, about as wide as a
# world face's extent), and the surfaces read the map over the face's wide cone (world_soft.glsl).
WORLD_TFM_SIDE = 64


@dataclass(frozen=True)
class FacePlan:
    """One face of a light that adds a light pass to the frame, before its maps are built.
    ``light_t``: how the pass finds the transmittance from the light (passes/scattering
    LIGHT_T_*; a TFM whose rays meet no density turns into LIGHT_T_NONE when built);
    ``tfm_side``: the TFM's side, texels, where ``light_t`` is LIGHT_T_TFM; ``shadow_map``: the
    face has a shadow map (some solid casts shadows and so does the light); ``field``: the media
    take the face's light from the world field (its pass lights the surfaces alone)."""

    light: Light
    frame: LightFrame
    reached: tuple[int, ...]        # the media (MediaGPU.boxes) the face reaches
    shadow_map: bool
    light_t: int
    tfm_side: int | None = None
    field: bool = False


@dataclass(frozen=True)
class FramePlan:
    """What one frame builds and draws. ``faces``: a light pass each, in order (none: one pass
    of ambient light, emission and surfaces alone); ``culled``: faces of point and area lights
    that reach neither a medium nor a solid the camera sees (no maps, no pass); ``passes``: the faces
    that draw a light pass, in order, a face whose light the camera's march carries first;
    ``lone``: one light pass writes the combined image itself, or adds its sample into the
    frame's sums (no composite pass); ``clear_targets``: zero the light passes' targets first (a
    frame of the active pixels alone); ``steps``: progress steps (scene, maps per light, G-buffer,
    a pass each)."""

    faces: tuple[FacePlan, ...]
    culled: int
    passes: tuple[FacePlan, ...]
    lone: bool
    clear_targets: bool
    steps: int

    @property
    def lightless_first(self) -> bool:
        """Whether the first pass (the one that marches the media for the view's transmittance,
        the world field, emission) lights with no face: no face's light is carried by the march."""
        return not self.passes or self.passes[0].field

    @property
    def tfm_side(self) -> int:
        """The largest TFM side of the frame (0: none), for the render report."""
        return max((f.tfm_side for f in self.faces if f.tfm_side is not None), default=0)


def plan_faces(scene: Scene, settings: RenderSettings, light: Light, media: MediaGPU, *,
               casts_shadows: bool, casters_bounds, seen_bounds, map_res: int,
               image_side: int | None = None, world_field: bool = False) -> tuple[list[FacePlan], int]:
    """The faces of ``light`` that add something to a frame of ``media`` (the media as uploaded:
    kind, boxes, slots), and how many were culled. ``casts_shadows``: some solid casts shadows;
    ``casters_bounds``, ``seen_bounds``: the boxes of the shadow casters and of the solids the
    camera sees (None: no culling by them); ``map_res``: the shadow maps' side, which caps the
    TFMs'; ``image_side``: the image side a FOOTPRINT TFM is capped by (default: the camera's);
    ``world_field``: the media take the world's light from the world field."""
    boxes = media.boxes
    fog = media.fog is not None                 # fog without bounds, alone or beside other media
    everywhere = media.kind == MEDIUM_EVERYWHERE or fog
    # Fog that absorbs takes all the light coming from infinitely far (a sun's), as in Cycles.
    sunless = fog and max(media.fog.sigma_t) > 0.0
    unit = settings.method == "UNSHADOWED" or not light.cast_shadow
    solid_names = {m.name for m in scene.shadow_casters}
    blocked = light.shadow_solids is None or any(n in solid_names for n in light.shadow_solids)
    side_cap = image_side or max(scene.camera.width_px, scene.camera.height_px)
    faces, culled = [], 0
    for frame in light_faces(light, boxes, casters_bounds):
        if sunless and frame.ortho:
            culled += 1
            continue
        reached = tuple(i for i, box in enumerate(boxes) if _reaches(light, frame, box))
        if (light.kind in ("POINT", "AREA") and not reached and not everywhere
                and (seen_bounds is None or not face_meets_box(frame, np.eye(4), *seen_bounds))):
            culled += 1
            continue
        light_t, side = LIGHT_T_NONE, None
        if media.kind == MEDIUM_GRID:
            if reached and unit:
                light_t = LIGHT_T_UNIT          # the floor, or a light nothing shadows
            elif reached and light.use_tfm:
                if settings.method == "BRUTE_FORCE":
                    light_t = LIGHT_T_MARCH
                else:
                    light_t = LIGHT_T_TFM
                    side = _face_side(settings, frame, media.slots, reached, map_res, side_cap)
                    if light.from_world and world_field:
                        side = min(side, WORLD_TFM_SIDE)
            elif fog:
                light_t = LIGHT_T_UNIT          # the fog alone: its closed form (shaders/world_fog.glsl)
        elif media.kind in (MEDIUM_BOX, MEDIUM_EVERYWHERE):
            if everywhere or reached:
                light_t = LIGHT_T_UNIT if unit else LIGHT_T_ANALYTIC
        shadow_map = bool(casts_shadows and light.cast_shadow and blocked)
        field = bool(world_field and light.from_world and light.lights_medium and reached)
        faces.append(FacePlan(light, frame, reached, shadow_map, light_t, side, field))
    return faces, culled


def plan_passes(faces, *, lights: int, accumulate: bool, active: bool, maps: bool = True,
                solids_seen: bool = True, background_image: bool = False) -> dict:
    """The passes of a frame of ``faces``, how it ends and what its progress counts: ``passes``,
    ``lone`` (see FramePlan), ``clear_targets``, ``steps``. ``accumulate``: the frame adds a
    sample into sums; ``active``: only the active pixels are shaded; ``maps``: the lights' maps
    are a step each (``lights`` of them; False where a later sample reuses the first one's);
    ``solids_seen``: the camera sees a solid (else a field face draws no pass);
    ``background_image``: the world seen behind everything varies with the direction (the
    composite pass draws it, the one pass with a texture unit free for it: never lone)."""
    passes = [f for f in faces if not f.field or (solids_seen and f.light.lights_surfaces)]
    passes.sort(key=lambda f: f.field)          # stable: the first face the march carries leads
    drawn = len(passes) + int(not passes or passes[0].field)
    return dict(passes=tuple(passes), lone=drawn <= 1 and (accumulate or not active) and not background_image,
                clear_targets=not accumulate and active,
                steps=2 + (lights if maps else 0) + drawn)


def plan_frame(scene: Scene, settings: RenderSettings, lights, media: MediaGPU, *, casts_shadows: bool,
               casters_bounds, seen_bounds, map_res: int, image_side: int | None = None,
               accumulate: bool = False, active: bool = False, world_field: bool = False) -> FramePlan:
    """The frame's plan: ``plan_faces`` for each of ``lights`` (those not dark), in order, and
    ``plan_passes``. ``world_field``: the GL can read a lattice's field (the media then take the
    world's light from it where a lattice covers them all: bounded media, no fog)."""
    faces, culled = [], 0
    field = world_field and media.fog is None and media.kind in (MEDIUM_GRID, MEDIUM_BOX)
    for light in lights:
        mine, dropped = plan_faces(scene, settings, light, media, casts_shadows=casts_shadows,
                                   casters_bounds=casters_bounds, seen_bounds=seen_bounds,
                                   map_res=map_res, image_side=image_side, world_field=field)
        faces += mine
        culled += dropped
    image = not settings.film_transparent and not isinstance(scene.background, tuple)
    return FramePlan(tuple(faces), culled, **plan_passes(faces, lights=len(lights), accumulate=accumulate,
                                                         active=active, solids_seen=seen_bounds is not None,
                                                         background_image=image))


def _face_side(settings, frame: LightFrame, slots, reached, map_res: int, image_side: int) -> int:
    """The TFM side of a face: the finest that the grids it reaches ask for (a homogeneous box has
    no voxel; it sets the side only where the face reaches no grid), whatever the media's order."""
    grids = [i for i in reached if slots[i].grid is not None] or reached
    return max(_face_tfm_resolution(settings, frame, slots[i], map_res, image_side) for i in grids)


def _face_tfm_resolution(settings, frame: LightFrame, slot: MediumSlot, map_res: int, image_side: int) -> int:
    """The TFM side of a face for one medium (passes/tfm.tfm_resolution, the FOOTPRINT rule read
    on ``slot``, at quality.footprint_texels_per_voxel of its density); an orthographic face's footprint
    is its extent over the voxel."""
    per_voxel = footprint_texels_per_voxel(slot.medium) if settings.tfm_resolution == "FOOTPRINT" else 1.0
    if frame.ortho and settings.tfm_resolution == "FOOTPRINT":
        voxel = float(np.linalg.norm(slot.box_to_world[:3, :3], axis=0).min())
        cap = min(map_res, max(int(image_side), MIN_FOOTPRINT_RESOLUTION))
        texels = per_voxel * 2.0 * max(frame.tan_xy) / max(voxel, 1e-12)
        return int(min(cap, max(MIN_FOOTPRINT_RESOLUTION, 16 * math.ceil(texels / 16))))
    return tfm_resolution(settings, frame, slot, map_res, image_side, per_voxel)


def _reaches(light: Light, frame: LightFrame, box) -> bool:
    """Whether the light's face reaches the box (a spot: its cone, within the frustum)."""
    if light.kind == "SPOT":
        return cone_meets_box(frame, *box)
    return face_meets_box(frame, *box)
