"""The evaluated depsgraph as the renderer's Scene: the only module that walks Blender's scene.

``extract`` reads the parts named by a Change flag and keeps the others from a previous
extraction, so the viewport re-reads only what an edit touched.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field, replace

import numpy as np

from ..engine import affine, caches, mesh_volume, shading
from ..engine.environment import Environment
from ..engine.medium_attributes import constant_emits
from ..engine.medium_grid import downsample
from ..engine.scene import Camera, GlowBlocks, GridValue, Light, Medium, Mesh, RenderSettings, Scene
from ..engine.scene import _digest as digest
from . import fluid, materials, meshes
from . import lights as lights_module
from .camera import camera_from_object
from .changes import Change
from .volumes import GridCache, NoGridThisFrame, VolumeReadError, grid_cache
from .world import ambient_radiance, environment, world_fog, world_visibility

RGB = tuple[float, float, float]


@dataclass(frozen=True)
class Extraction:
    """A scene read from Blender, part by part, with the warnings each part raised."""

    camera: Camera | None = None
    lights: tuple[Light, ...] = ()
    meshes: tuple[Mesh, ...] = ()
    ambient: RGB = (0.0, 0.0, 0.0)
    settings: RenderSettings = field(default_factory=RenderSettings)
    warnings: dict[Change, tuple[str, ...]] = field(default_factory=dict)
    media: tuple[Medium, ...] = ()    # every medium (volume objects, meshes with volume materials)
    medium_sources: tuple[str, ...] = ()   # the objects they come from
    world_fog: Medium | None = None   # the World's Volume output, fog filling the scene
    environment: Environment | None = None   # the world's radiance by direction, or None (constant)
    world_visibility: tuple[bool, bool, bool] = (True, True, True)   # camera, volume scatter, diffuse

    def scene(self, camera: Camera | None = None) -> Scene:
        cam = camera if camera is not None else self.camera
        if cam is None:
            raise ValueError("no camera")
        media = self.media if self.world_fog is None else (*self.media, self.world_fog)
        seen, medium, surfaces = self.world_visibility
        return Scene(camera=cam, lights=self.lights, media=media, meshes=self.meshes,
                     ambient=self.ambient if self.settings.ambient else (0.0, 0.0, 0.0),
                     world=(0.0, 0.0, 0.0) if not seen else None if self.environment is not None
                     else self.ambient, environment=self.environment,
                     world_lights_medium=medium, world_lights_surfaces=surfaces)

    @property
    def all_warnings(self) -> list[str]:
        return [w for part in Change if part in self.warnings for w in self.warnings[part]]


class WalkCache:
    """What a viewport keeps between walks of the depsgraph, per object: the triangles of each
    evaluated mesh, the grids of generated volumes and the last walk's ``Mesh`` values. The
    depsgraph says which objects changed their geometry (``forget`` their entries); an object
    that only moved keeps its triangles and grid and is placed anew by its matrix. ``counters``:
    'triangulations' (meshes read), 'triangles_reused', 'grids_reused', 'solids_reused'."""

    def __init__(self):
        self.counters: Counter = Counter()
        self._arrays: dict = {}     # key of an evaluated mesh -> [(vertices, triangles) | None, owners]
        self._grids: dict = {}      # key of an evaluated volume -> [(grid, notes), owners]
        self._solids: dict = {}     # label -> the Mesh of the last walk that read the solids
        self._next_solids: dict = {}
        self._used: set = set()     # keys of the triangles the current walk used

    def clear(self) -> None:
        self._arrays.clear()
        self._grids.clear()
        self._solids.clear()

    def forget(self, names) -> None:
        """Drop what was read from the objects or data-blocks named (their geometry changed)."""
        names = set(names)
        for table in (self._arrays, self._grids):
            for key in [k for k, (_, owners) in table.items() if owners & names]:
                del table[key]

    def forget_grids(self) -> None:
        self._grids.clear()

    def walk(self) -> _Arrays:
        return _Arrays(self)

    def grid(self, key):
        entry = self._grids.get(key)
        if entry is None:
            return None
        self.counters["grids_reused"] += 1
        return entry[0]

    def keep_grid(self, key, value, owners) -> None:
        self._grids[key] = [value, set(owners)]

    def solid(self, mesh: Mesh) -> Mesh:
        """``mesh``, or the last walk's equal Mesh (its arrays and keys already made)."""
        prev = self._solids.get(mesh.name)
        if prev is not None and _same_solid(prev, mesh):
            self.counters["solids_reused"] += 1
            mesh = prev
        self._next_solids[mesh.name] = mesh
        return mesh

    def walked(self, solids: bool, everything: bool) -> None:
        """End of a walk: keep its solids (when it read them); after a walk that visited every
        mesh, drop the triangles of meshes it no longer has."""
        if solids:
            self._solids = self._next_solids
        self._next_solids = {}
        if everything:
            used = self._used
            for key in [k for k in self._arrays if k not in used]:
                del self._arrays[key]
        self._used = set()


def _same_solid(a: Mesh, b: Mesh) -> bool:
    def buffer(x):
        return x.__array_interface__["data"][0], x.shape
    return (buffer(a.vertices) == buffer(b.vertices) and buffer(a.triangles) == buffer(b.triangles)
            and np.array_equal(a.matrix_world, b.matrix_world) and a.color == b.color
            and (a.visible_camera, a.cast_shadow, a.holdout) == (b.visible_camera, b.cast_shadow, b.holdout))


def _owners(instance) -> set[str]:
    """The objects and data-blocks whose geometry update makes what was read from ``instance``
    stale: the object, its data, and its instancer."""
    ob = instance.object
    names = {ob.name}
    data = getattr(ob, "data", None)
    if data is not None:
        names.add(data.name)
    if instance.is_instance and instance.parent is not None:
        names.add(instance.parent.name)
    return names


class _Arrays:
    """One walk's triangles: each evaluated mesh read once in the walk (its instances share it),
    and taken from the WalkCache when an earlier walk read it and no geometry update came since."""

    def __init__(self, kept: WalkCache):
        self.kept = kept
        self.seen: dict = {}

    def get(self, instance):
        ob = instance.object
        if ob.type == 'MESH':
            data = ob.data
            key = ("mesh", data.as_pointer(), data.name, len(data.vertices), len(data.polygons))
            lasting = True
        else:      # a temporary instance object's address is reused by the next instance
            key = ("object", ob.as_pointer(), ob.name)
            lasting = not instance.is_instance
        if key in self.seen:
            return self.seen[key]
        entry = self.kept._arrays.get(key) if lasting else None
        if entry is None:
            result = meshes.triangles(ob)
            self.kept.counters["triangulations"] += 1
            if lasting:
                self.kept._arrays[key] = [result, _owners(instance)]
        else:
            result = entry[0]
            entry[1] |= _owners(instance)
            self.kept.counters["triangles_reused"] += 1
        if lasting:
            self.kept._used.add(key)
        self.seen[key] = result
        return result


def render_settings(scene, viewport: bool = False) -> RenderSettings:
    """RenderSettings from the scene's TFM properties."""
    tfm = scene.tfm
    return RenderSettings(
        tfm_filter=tfm.tfm_filter,
        view_steps=tfm.view_steps,
        light_steps=tfm.light_steps,
        coefficients=tfm.coefficients,
        density_weight=None if tfm.density_weight_auto else tfm.density_weight,
        map_resolution=tfm.map_resolution,
        sampling=tfm.sampling,
        method=tfm.method,
        ambient=tfm.ambient,
        quality=tfm.quality,
        film_transparent=bool(scene.render.film_transparent),
        world_light=getattr(tfm, "world_light", 'UNSHADOWED'),
        world_directions=int(getattr(tfm, "world_directions", 16)),
        volume_bounces=volume_bounces(scene),
    )


def volume_bounces(scene) -> int:
    """The TFM Volume Bounces, or where it is -1, Cycles' (``scene.cycles.volume_bounces``; 0
    where the Cycles add-on is off)."""
    own = int(getattr(scene.tfm, "volume_bounces", -1))
    if own >= 0:
        return own
    return max(int(getattr(getattr(scene, "cycles", None), "volume_bounces", 0)), 0)


def render_size(scene) -> tuple[int, int]:
    """Output size in pixels after the resolution percentage."""
    r = scene.render
    return (int(r.resolution_x * r.resolution_percentage / 100),
            int(r.resolution_y * r.resolution_percentage / 100))


def extract(depsgraph, *, parts: Change = Change.ALL, previous: Extraction | None = None,
            camera_object=None, size: tuple[int, int] | None = None, window=None,
            cache: GridCache | None = None, volume_resolution: int | None = None,
            kept: WalkCache | None = None) -> Extraction:
    """Read ``parts`` of the scene from an evaluated depsgraph; take the rest from ``previous``.

    ``camera_object``: the camera to render through (default: the scene's); ``size``: image size
    in pixels (default: the scene's output size); ``window``: a render border's pixel window;
    ``volume_resolution``: voxels along a mesh medium's longest side (default: from the size);
    ``kept``: what earlier walks read per object (the viewport's), reused where the depsgraph
    reported no geometry update (``WalkCache.forget``); None: everything is read afresh.
    """
    if previous is None:
        previous, parts = Extraction(), Change.ALL
    cache = grid_cache if cache is None else cache
    scene = depsgraph.scene
    changes: dict = {}
    warnings = dict(previous.warnings)

    if Change.SETTINGS in parts:
        changes["settings"] = render_settings(scene, viewport=depsgraph.mode != 'RENDER')
        warnings[Change.SETTINGS] = tuple(_settings_warnings(scene))

    if Change.CAMERA in parts:
        notes: list[str] = []
        cam_ob = camera_object if camera_object is not None else scene.camera
        if cam_ob is None:
            changes["camera"] = None
        else:
            cam_ob = cam_ob.evaluated_get(depsgraph)
            width, height = size if size is not None else render_size(scene)
            changes["camera"] = camera_from_object(cam_ob, width, height, window=window, warnings=notes)
        warnings[Change.CAMERA] = tuple(notes)

    if Change.WORLD in parts:
        wait = depsgraph.mode == 'RENDER'       # the viewport bakes a Sky Texture in the background
        ambient, note = ambient_radiance(scene.world, wait)
        changes["ambient"] = tuple(float(c) for c in ambient)
        fog, fog_notes = world_fog(scene.world)
        changes["world_fog"] = fog
        changes["environment"] = environment(scene.world, wait)[0] if scene.world is not None else None
        changes["world_visibility"] = world_visibility(scene.world)
        warnings[Change.WORLD] = ((note,) if note else ()) + tuple(fog_notes)

    geometry = parts & Change.GEOMETRY
    if geometry:
        if volume_resolution is None:
            volume_resolution = mesh_volume_resolution(size if size is not None else render_size(scene))
        found = _walk_instances(depsgraph, geometry, cache, volume_resolution, kept)
        for part, key in ((Change.LIGHTS, "lights"), (Change.SOLIDS, "meshes")):
            if part in geometry:
                changes[key] = tuple(found[key])
                warnings[part] = tuple(found["warnings"][part])
        if Change.MEDIUM in geometry:
            changes["media"] = tuple(found["media"])
            changes["medium_sources"] = tuple(found["medium_sources"])
            warnings[Change.MEDIUM] = tuple(found["warnings"][Change.MEDIUM])

    return replace(previous, warnings=warnings, **changes)


def scene_state(depsgraph) -> dict:
    """What a Scene update may change that renders, read without touching geometry: the render
    settings, the world, the frame, the output size (a mesh medium's resolution follows it),
    Simplify's volume level and the census of object instances (what shows, with its
    visibility). A selection or an active object change leaves it equal."""
    scene = depsgraph.scene
    census = []
    for instance in depsgraph.object_instances:
        ob = instance.object
        entry = (_label(instance), ob.type, instance.show_self, instance.show_particles)
        if ob.type in meshes.MESH_TYPES:
            entry += tuple(meshes.visibility(instance, depsgraph.view_layer).values())
        census.append(entry)
    return {"settings": (render_settings(scene, viewport=depsgraph.mode != 'RENDER'),
                         tuple(_settings_warnings(scene))),
            "world": (ambient_radiance(scene.world, depsgraph.mode == 'RENDER'),
                      world_visibility(scene.world)),
            "frame": (scene.frame_current, float(scene.frame_subframe)),
            "size": render_size(scene),
            "simplify": volume_simplify_level(depsgraph),
            "census": tuple(census)}


def scene_changes(before: dict | None, after: dict) -> Change:
    """The parts a Scene update made stale, from the states (``scene_state``) before and after."""
    if before is None:
        return Change.ALL
    flags = Change.NONE
    if before["settings"] != after["settings"]:
        flags |= Change.SETTINGS
    if before["world"] != after["world"]:
        flags |= Change.WORLD
    if before["size"] != after["size"] or before["simplify"] != after["simplify"]:
        flags |= Change.MEDIUM
    if before["frame"] != after["frame"] or before["census"] != after["census"]:
        flags |= Change.GEOMETRY
    return flags


def _settings_warnings(scene) -> list[str]:
    r = scene.render
    notes = []
    if r.pixel_aspect_x != r.pixel_aspect_y:
        notes.append("Non-square pixel aspect is not supported; rendering square pixels")
    ignored = []
    if r.use_multiview:
        ignored.append("stereoscopy (every view renders from the camera's centre)")
    if ignored:
        notes.append("Not rendered by TFM: " + "; ".join(ignored))
    return notes


def volume_simplify_level(depsgraph) -> int:
    """Blender's volume simplify level: the grid is halved this many times. Simplify's Volume
    Resolution is a viewport setting (Render Properties ▸ Simplify ▸ Viewport): a final render's
    depsgraph reads full grids, as in Blender (``BKE_volume_simplify_level``)."""
    r = depsgraph.scene.render
    if depsgraph.mode == 'RENDER' or not r.use_simplify:
        return 0
    factor = float(r.simplify_volumes)
    return 16 if factor <= 0.0 else max(0, math.ceil(-math.log2(min(factor, 1.0))))


# (id of the full grid, level) -> (the full grid, simplified grid, matrix): the last one
_simplified = caches.memo("extract.simplified grid", 1)
# (id of a full attribute grid, level) -> (that grid, simplified): the last frame's
_simplified_extras = caches.memo("extract.simplified attributes", 8)


def simplify_grid(density: np.ndarray, index_to_object: np.ndarray, level: int):
    """The grid at 1/2^level of its resolution (means of 2^level-voxel blocks) and its matrix;
    the last result is kept, so viewport edits that keep the grid do not redo it."""
    if level <= 0:
        return density, index_to_object
    key = (id(density), level)
    hit = _simplified.get(key)
    if hit is None or hit[0] is not density:
        f = 2 ** level
        scale = np.diag([float(f)] * 3 + [1.0])
        scale[:3, 3] = (f - 1) / 2.0   # block i's centre sits at index i f + (f - 1) / 2
        small = downsample(density, f)
        small.setflags(write=False)
        hit = _simplified.put(key, (density, small, scale))
    return hit[1], np.asarray(index_to_object) @ hit[2]


def _label(instance) -> str:
    ob = instance.object
    if instance.is_instance and instance.parent is not None:
        return f"{ob.name} (instanced by {instance.parent.name})"
    return ob.name


def mesh_volume_resolution(size: tuple[int, int]) -> int:
    """Voxels along a mesh medium's longest side, from the image size only (so that no camera
    move changes it): about one voxel per pixel of the longer image side, rounded down to 32, 48,
    64, 96 or 128 (docs/benchmark.md, "Measurements behind design choices", has the measurements)."""
    want = max(size)
    steps = (32, 48, 64, 96, 128)
    return max([n for n in steps if n <= want], default=steps[0])


def degenerate(matrix_world, placed: bool = True) -> str | None:
    """Why an object at ``matrix_world`` cannot be rendered, or None: a matrix with a NaN or an
    infinity, or (``placed``: media, whose inverse the renderer needs) a zero scale along some
    axis (a smoke that grows from scale 0, a flattened volume)."""
    m = np.asarray(matrix_world, np.float64)
    if not np.isfinite(m).all():
        return "its transform is not finite (NaN or infinity)"
    if placed:
        s = np.linalg.svd(m[:3, :3], compute_uv=False)
        if s[0] <= 0.0 or s[-1] <= 1e-9 * s[0]:
            return "its scale is zero along some axis"
    return None


def _light_linking(depsgraph, light_objects: list, lights: list[Light], warnings: list[str]) -> list[Light]:
    """The lights as their receiver and blocker collections let them light the media and the solids
    and be shadowed by them (lights.linked), the objects classified as the walk does."""
    def has_links(o) -> bool:
        linking = getattr(o, "light_linking", None)
        return linking is not None and (linking.receiver_collection is not None
                                        or linking.blocker_collection is not None)

    if not any(has_links(o) for o in light_objects):
        return lights
    media, solids = [], []
    for ob in depsgraph.objects:
        if ob.type == 'VOLUME':
            media.append(ob.name)
        elif ob.type in meshes.MESH_TYPES:
            medium = (fluid.domain_modifier(ob, depsgraph.mode == 'RENDER') is not None
                      or materials.has_volume_only(meshes.first_material(ob)))
            (media if medium else solids).append(ob.name)
    return [lights_module.linked(o, light, media, solids, warnings)
            for o, light in zip(light_objects, lights, strict=True)]


def _walk_instances(depsgraph, parts: Change, cache: GridCache,
                    volume_resolution: int = mesh_volume.DEFAULT_RESOLUTION,
                    kept: WalkCache | None = None) -> dict:
    """Lights, meshes and the medium among the depsgraph's object instances."""
    spots: list[Light] = []
    light_objects: list = []          # the object of each of ``spots``
    solids: list[Mesh] = []
    skipped_lights: list[str] = []
    media: list[str] = []
    found_media: list[Medium] = []     # every medium, in the depsgraph's order
    sources: list[str] = []
    notes = {Change.LIGHTS: [], Change.SOLIDS: [], Change.MEDIUM: []}
    kept = WalkCache() if kept is None else kept   # arrays shared by the instances of a mesh
    arrays = kept.walk()
    simplify = volume_simplify_level(depsgraph) if Change.MEDIUM in parts else 0
    unrendered: dict[str, list[str]] = {}   # kind of object TFM does not render -> names
    colour_notes: list[str] = []
    degenerate_notes: dict[Change, list[str]] = {}

    for instance in depsgraph.object_instances:
        ob = instance.object
        kind = ob.type
        if not instance.show_self:
            # a particle or instancing emitter set not to show itself (its hair would show)
            if parts & Change.SOLIDS and instance.show_particles and _has_hair(ob):
                unrendered.setdefault("Hair particles", []).append(_label(instance))
            continue
        if kind in UNRENDERED_TYPES and parts & Change.SOLIDS:
            unrendered.setdefault(UNRENDERED_TYPES[kind], []).append(_label(instance))
            continue
        if kind in PLACED_TYPES:
            # A medium needs its matrix's inverse; a solid only its world triangles (a mesh
            # flattened to a plane renders as one) and a light only finite numbers.
            medium_like = kind == 'VOLUME' or (kind in meshes.MESH_TYPES and (
                fluid.domain_modifier(ob, depsgraph.mode == 'RENDER') is not None
                or materials.has_volume_only(meshes.first_material(ob))))
            reason = degenerate(instance.matrix_world, placed=medium_like)
            if reason is not None:      # skipped with one line; the rest of the frame renders
                part = Change.LIGHTS if kind == 'LIGHT' else (
                    Change.MEDIUM if Change.MEDIUM in parts else Change.SOLIDS)
                if part in parts:
                    degenerate_notes.setdefault(part, []).append(
                        f"Object '{_label(instance)}' is not rendered in this frame: {reason}")
                continue
        if kind == 'LIGHT' and Change.LIGHTS in parts:
            if ob.data.type in ('SPOT', 'POINT', 'SUN', 'AREA'):
                spots.append(lights_module.light(ob, np.array(instance.matrix_world), notes[Change.LIGHTS]))
                light_objects.append(ob)
            else:
                skipped_lights.append(f"{ob.name} ({ob.data.type.lower()})")
        elif kind == 'VOLUME' and Change.MEDIUM in parts:
            media.append(_label(instance))
            found = _volume_medium(instance, cache, notes[Change.MEDIUM], simplify, kept, depsgraph)
            _medium_visibility_notes(depsgraph, instance, notes[Change.MEDIUM])
            if found is not None:
                found_media.append(replace(found, name=_label(instance),
                                           **_emission_reach(instance)))
                sources.append(_label(instance))
        elif kind == 'MESH' and fluid.domain_modifier(ob, depsgraph.mode == 'RENDER') is not None:
            if Change.MEDIUM in parts:   # a smoke / fire domain: its cache, never its mesh
                media.append(_label(instance))
                found = _fluid_medium(instance, depsgraph.scene.frame_current, cache,
                                      notes[Change.MEDIUM], simplify)
                _medium_visibility_notes(depsgraph, instance, notes[Change.MEDIUM])
                if found is not None:
                    found_media.append(replace(found, name=_label(instance),
                                               **_emission_reach(instance)))
                    sources.append(_label(instance))
        elif kind in meshes.MESH_TYPES and parts & (Change.SOLIDS | Change.MEDIUM):
            material = meshes.first_material(ob)
            if Change.SOLIDS in parts and materials.has_surface_and_volume(material):
                note = (f"Material '{material.name}' has a surface and a volume shader: the surface is "
                        f"rendered as an opaque diffuse solid and the volume inside it is not rendered")
                if note not in notes[Change.SOLIDS]:
                    notes[Change.SOLIDS].append(note)
            if materials.has_volume_only(material):
                if Change.MEDIUM in parts:
                    media.append(_label(instance))
                    found = _mesh_medium(instance, material, notes[Change.MEDIUM], volume_resolution,
                                         arrays)
                    _medium_visibility_notes(depsgraph, instance, notes[Change.MEDIUM])
                    if found is not None:
                        found_media.append(replace(found, name=_label(instance),
                                                   **_emission_reach(instance)))
                        sources.append(_label(instance))
                continue
            if Change.SOLIDS not in parts:
                continue
            if _has_hair(ob):
                unrendered.setdefault("Hair particles", []).append(_label(instance))
            mesh = arrays.get(instance)
            if mesh is None:
                continue
            vertices, tris, uv, normals = mesh
            flags = meshes.visibility(instance, depsgraph.view_layer)
            if flags["visible_camera"] and materials.hidden_from_camera(material):
                flags["visible_camera"] = False
            seen = colour_notes if flags["visible_camera"] else None   # an unseen colour needs no note
            shading = meshes.shading(ob, seen)
            textured = shading["surface"] is not None and shading["surface"].base_texture is not None
            solids.append(kept.solid(Mesh(vertices=vertices, triangles=tris,
                                          matrix_world=np.array(instance.matrix_world),
                                          **shading, uv=uv if textured else None, normals=normals,
                                          name=_label(instance),
                                          **flags)))

    notes[Change.SOLIDS].extend(dict.fromkeys(colour_notes))   # once per material
    for part, lines in degenerate_notes.items():
        notes[part].extend(dict.fromkeys(lines))
    if Change.LIGHTS in parts:
        spots = _light_linking(depsgraph, light_objects, spots, notes[Change.LIGHTS])
        if skipped_lights:
            notes[Change.LIGHTS].append(
                "Lights of unknown type are not rendered: " + ", ".join(skipped_lights))
        # A scene without lights is the renderer's to explain (it says so in its warnings).
    for what, names in unrendered.items():
        notes[Change.SOLIDS].append(f"{what} are not rendered by TFM: " + ", ".join(names))
    kept.walked(Change.SOLIDS in parts, (Change.SOLIDS | Change.MEDIUM) in parts)
    return {"lights": spots, "meshes": solids, "media": found_media, "medium_sources": sources,
            "warnings": notes}


def _has_hair(ob) -> bool:
    return any(ps.settings.type == 'HAIR' and ps.settings.render_type == 'PATH'
               for ps in getattr(ob, "particle_systems", ()))


# Object types TFM does not render, and how the render report names them.
UNRENDERED_TYPES = {'CURVES': "Hair curves", 'POINTCLOUD': "Point clouds"}
# Objects whose matrix places what is rendered (degenerate() checks it before they are read).
PLACED_TYPES = {'LIGHT', 'VOLUME'} | meshes.MESH_TYPES


def _emission_reach(instance) -> dict:
    """What a medium's emission lights: the surfaces where Cycles' Diffuse ray visibility of its
    object (and its instancer's) is on, the media where its Volume Scatter visibility is."""
    owners = [instance.object]
    if instance.is_instance and instance.parent is not None:
        owners.append(instance.parent)
    return {"lights_surfaces": all(o.visible_diffuse for o in owners),
            "lights_medium": all(getattr(o, "visible_volume_scatter", True) for o in owners)}


def _medium_visibility_notes(depsgraph, instance, notes: list[str]) -> None:
    """The medium is always seen and always shadows: say so when its object asks otherwise."""
    flags = meshes.visibility(instance, depsgraph.view_layer)
    ignored = [what for what, on in (("hidden from the camera", not flags["visible_camera"]),
                                     ("casting no shadow", not flags["cast_shadow"]),
                                     ("holdout", flags["holdout"])) if on]
    if ignored:
        notes.append(f"Medium '{_label(instance)}': " + ", ".join(ignored)
                     + " is not rendered by TFM (the medium is seen and shadows)")


def _box_matrix(lo, hi) -> np.ndarray:
    """Matrix mapping the cube [-1, 1]^3 onto the box [lo, hi]."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    m = np.diag([*((hi - lo) / 2.0), 1.0])
    m[:3, 3] = (hi + lo) / 2.0
    return m


def _grid_value(e: affine.Expr) -> GridValue:
    return GridValue(e.grid, e.scale, e.offset) if e.grid else GridValue(offset=e.offset)


def _sigma(material, settings, label: str, notes: list[str], available=None) -> dict:
    """What a medium's material gives: 'fields' (Medium keyword arguments besides the grids), the
    density 'grid' the material reads (None: constant), 'constant' (the density is constant), and
    'grids' (every grid it reads). ``available``: the volume's grid names (None: unknown)."""
    use_nodes = settings is None or settings.use_node_material
    if use_nodes and material is None and settings is not None:
        # Cycles' default volume shader: a Principled Volume at its defaults
        return dict(fields=dict(sigma_a=(0.5, 0.5, 0.5), sigma_s=(0.5, 0.5, 0.5), anisotropy=0.0),
                    grid="density", constant=False, grids=("density",))
    if use_nodes and material is not None:
        graph, reason = materials.volume_graph(material)
        sigma = None
        if graph is not None:
            try:        # the fast path: constants times one grid (engine/affine.py)
                sigma = affine.fold(graph, available, material.name)
            except affine.NotAffine:
                pass
            if sigma is not None and sigma.grid is None and sigma.grids:
                sigma = None        # a constant density beside grids (an emission): evaluated per voxel
        if graph is not None and sigma is None:
            # a graph that is not scale x grid + offset: evaluated per voxel (engine/shading.py)
            notes.extend(f"{label}: {note}" for note in graph.notes)
            return dict(fields={}, grid=None, constant=False, grids=graph.grids, graph=graph,
                        from_material=True)
        if sigma is not None:
            notes.extend(f"{label}: {note}" for note in sigma.notes)
            fields = dict(sigma_a=sigma.sigma_a, sigma_s=sigma.sigma_s, anisotropy=sigma.anisotropy,
                          color_grid=sigma.color_grid, emission_color=sigma.emission_color,
                          emission_strength=_grid_value(sigma.emission_strength),
                          blackbody_intensity=_grid_value(sigma.blackbody_intensity),
                          blackbody_tint=sigma.blackbody_tint, temperature=_grid_value(sigma.temperature))
            return dict(fields=fields, grid=sigma.grid, constant=sigma.grid is None, grids=sigma.grids,
                        from_material=True)
        notes.append(f"{label}: {reason}")
    if settings is None:
        return dict(fields=dict(sigma_a=(0.1, 0.1, 0.1), sigma_s=(1.0, 1.0, 1.0), anisotropy=0.0),
                    grid=None, constant=False, grids=())
    k = settings.density_scale
    fields = dict(sigma_a=tuple(k * c for c in settings.sigma_a),
                  sigma_s=tuple(k * c for c in settings.sigma_s), anisotropy=settings.anisotropy)
    grids: tuple = ()
    strength = float(getattr(settings, "emission_strength", 0.0))
    if strength > 0.0:
        name = getattr(settings, "emission_grid", "")
        has = bool(name) and (available is None or name in available)
        fields.update(emission_color=tuple(settings.emission_color),
                      emission_strength=GridValue(name, strength, 0.0) if has else GridValue(offset=strength))
        grids = (name,) if has else ()
    return dict(fields=fields, grid=None, constant=False, grids=grids)


def _may_read_sparse(read: dict) -> bool:
    """Whether the volume's material lets its density be read as bricks (volumes.read_sparse): an
    affine material without emission (volumes.read_grid_set reads bricks only where no other grid
    is read), which the renderer's sparse path renders in full."""
    fields = read["fields"]
    emits = any(isinstance(v, GridValue) and (v.grid is not None or v.offset > 0.0)
                for v in (fields.get("emission_strength"), fields.get("blackbody_intensity")))
    return read.get("graph") is None and not read["constant"] and not emits


def _drop_missing(fields: dict, extras: dict, label: str, notes: list[str],
                  why: str = "was not found") -> dict:
    """Fields whose grids were not read fall back to their constants, with a note."""
    out = dict(fields)
    for key in ("emission_strength", "blackbody_intensity", "temperature"):
        v = out.get(key)
        if isinstance(v, GridValue) and v.grid is not None and (v.grid not in extras
                                                                or extras[v.grid].ndim != 3):
            notes.append(f"{label}: grid '{v.grid}' {why} (or is not a float grid); its socket reads "
                         f"{v.offset:g}")
            out[key] = GridValue(offset=v.offset)
    if out.get("color_grid") and (out["color_grid"] not in extras or extras[out["color_grid"]].ndim != 4):
        notes.append(f"{label}: colour grid '{out['color_grid']}' {why} (or is not a vector grid)")
        out["color_grid"] = None
    return out


def _volume_medium(instance, cache: GridCache, notes: list[str], simplify: int = 0,
                   kept: WalkCache | None = None, depsgraph=None) -> Medium | None:
    """A Volume object's medium. A generated volume's grids (saved and hashed to be read) are
    kept in ``kept`` until its geometry changes: moving it only places them anew."""
    ob = instance.object
    volume = ob.data
    label = f"Volume '{_label(instance)}'"
    settings = getattr(volume, "tfm", None)
    preferred = settings.density_grid if settings is not None else "density"
    generated = (not volume.filepath or len(ob.original.modifiers) > 0
                 or (instance.is_instance and instance.parent is not None
                     and len(instance.parent.original.modifiers) > 0))
    try:
        available = [name for name, _ in cache.grid_types(volume, _label(instance))]
    except NoGridThisFrame:
        return None
    except VolumeReadError as ex:
        notes.append(f"{ex}; rendering without it")
        return None
    read = _sigma(meshes.first_material(ob), settings, label, notes, available)
    if read.get("graph") is not None:       # Generated coordinates span the object's bounds
        corners = np.asarray([tuple(c) for c in ob.bound_box], np.float64)
        lo, hi = corners.min(axis=0), corners.max(axis=0)
        read["graph"] = replace(read["graph"], texspace=(tuple((lo + hi) / 2.0), tuple((hi - lo) / 2.0)))
    material_grid = read["grid"]
    memo, owners = None, _owners(instance)
    if generated and kept is not None and depsgraph is not None:
        memo = ("volume", volume.as_pointer(), volume.name, _label(instance), preferred,
                tuple(read["grids"]))
        shape = _mesh_to_volume_inputs(depsgraph, instance)
        if shape is not None:     # what its grid is made of, however Blender flags the object
            memo, owners = memo[2:] + shape[0], shape[1]
    try:
        found = kept.grid(memo) if memo is not None else None
        if found is None:
            found = cache.read(volume, preferred, _label(instance), generated=generated,
                               extras=tuple(read["grids"]), sparse=_may_read_sparse(read),
                               wait=depsgraph is None or depsgraph.mode == 'RENDER')
            if memo is not None:
                kept.keep_grid(memo, found, owners)
        grid, grid_notes = found
    except NoGridThisFrame:
        return None
    except VolumeReadError as ex:
        notes.append(f"{ex}; rendering without it")
        return None
    notes.extend(grid_notes)
    if material_grid and material_grid != grid.grid_name:
        notes.append(f"{label}: the material reads grid '{material_grid}', the density comes from "
                     f"grid '{grid.grid_name}' (set in the volume's TFM panel)")
    if read.get("from_material") and not read["grids"] and read["grid"] is None:
        notes.append(f"{label}: its volume shader reads no grid, so it renders nothing (as in Cycles)")
        return None
    matrix = np.array(instance.matrix_world)
    medium = _grid_medium(matrix, grid, read, label, notes, simplify,
                          float(getattr(volume.render, "clipping", 0.0)))
    if medium is None:
        return None
    if getattr(volume.render, "space", 'OBJECT') == 'OBJECT':
        medium = object_space(medium, matrix)
    return medium


_MESH_TO_VOLUME_SETTINGS = ("density", "interior_band_width", "resolution_mode", "voxel_amount",
                            "voxel_size")


def _mesh_to_volume_inputs(depsgraph, instance):
    """For a Volume object (not an instance) whose modifiers are all Mesh to Volume: what its
    grids are made of (each modifier's settings and its mesh's placement relative to the volume
    object) and the names whose geometry update changes them (the meshes read); None otherwise.
    Blender re-evaluates such a volume whenever either object moves; its grids change only when
    the mesh moves relative to it, so a move of both together (a parent's) keeps them."""
    if instance.is_instance:
        return None
    ob = instance.object
    original = ob.original
    modifiers = list(original.modifiers)
    if not modifiers or any(m.type != 'MESH_TO_VOLUME' for m in modifiers):
        return None
    to_local = np.linalg.inv(np.array(ob.matrix_world))
    parts, owners = [original.data.filepath, bool(original.data.is_sequence)], set()
    for m in modifiers:
        if not m.show_viewport:
            parts.append(None)
            continue
        source = m.object
        if source is None:
            parts.append(("no mesh",))
            continue
        evaluated = source.evaluated_get(depsgraph)
        relative = to_local @ np.array(evaluated.matrix_world)
        parts.append((source.name, tuple(np.round(relative, 12).ravel()),
                      tuple(getattr(m, k, None) for k in _MESH_TO_VOLUME_SETTINGS)))
        owners |= {source.name, source.data.name if source.data is not None else source.name}
    return tuple(parts), owners


def object_space(medium: Medium, matrix_world: np.ndarray) -> Medium:
    """Volume ▸ Render ▸ Space Object: Cycles divides the density (and the emission) by the
    object's scale, the length of its matrix applied to the unit diagonal (1, 1, 1)/sqrt(3), so a
    volume looks the same however it is scaled (intern/cycles/scene/object.cpp)."""
    diagonal = np.asarray(matrix_world, np.float64)[:3, :3] @ (np.ones(3) / math.sqrt(3.0))
    length = float(np.linalg.norm(diagonal))
    if length <= 0.0 or not math.isfinite(length) or abs(length - 1.0) < 1e-9:
        return medium
    f = 1.0 / length
    if medium.shader is not None:      # a graph evaluated later: the factor goes with it
        source = replace(medium.shader, density_scale=f, key=digest(medium.shader.key, f))
        return replace(medium, shader=source, source_key=source.key)
    return replace(medium, sigma_a=tuple(f * c for c in medium.sigma_a),
                   sigma_s=tuple(f * c for c in medium.sigma_s),
                   emission_color=tuple(f * c for c in medium.emission_color),
                   blackbody_tint=tuple(f * c for c in medium.blackbody_tint))


def _grid_medium(matrix_world, grid, read: dict, label: str, notes: list[str], simplify: int = 0,
                 clipping: float = 0.0) -> Medium | None:
    """The medium of a grid read for an object placed by ``matrix_world``; ``simplify`` halves
    the grids that many times (Simplify's volume resolution), ``clipping`` empties lower densities."""
    if read.get("graph") is not None:
        return _graph_medium(matrix_world, grid, read["graph"], label, notes, simplify, clipping)
    fields = read["fields"]
    to_world = matrix_world @ grid.index_to_object
    if read["constant"]:
        n = np.asarray(grid.density.shape, dtype=np.float64)
        box = to_world @ _box_matrix(-0.5 * np.ones(3), n - 0.5)
        fields = _drop_missing(fields, {}, label, notes, "is not rendered with a constant density")
        return Medium(box_to_world=box, **fields)
    available = {getattr(grid, "grid_name", "density"): grid.density, **grid.extras}   # the density too
    fields = _drop_missing(fields, available, label, notes)
    used = {v.grid for v in (fields.get("emission_strength"), fields.get("blackbody_intensity"),
                             fields.get("temperature")) if isinstance(v, GridValue) and v.grid}
    used |= {fields["color_grid"]} if fields.get("color_grid") else set()
    extras = {name: a for name, a in available.items() if name in used}
    sparse = getattr(grid, "sparse", None)
    if sparse is not None:
        simplify = 0         # bricks: the whole resolution, whatever Simplify asks
    density, voxel_clipping = grid.density, clipping
    if clipping > 0.0 and sparse is None and grid.bounds is None:     # Cycles' bounds, not per voxel
        read_extras = tuple(n for n in extras if n in grid.extras)
        density, voxel_clipping = within_bounds(grid, read_extras, clipping), 0.0
    density, index_to_object = simplify_grid(density, grid.index_to_object, simplify)
    if simplify > 0:
        extras = _simplify_extras(extras, simplify)
    medium = Medium(density=density, index_to_world=matrix_world @ index_to_object, grids=extras,
                    clipping=voxel_clipping, sparse=sparse,
                    source_key=digest(grid.key, sorted(extras), simplify) if grid.key else None, **fields)
    if constant_emits(medium):     # it glows where there is no density: over Cycles' volume mesh
        if grid.bounds is not None:         # drawn by its object's mesh (a fluid domain's cube)
            lo, hi = (np.asarray(c, np.float64) for c in grid.bounds)
            glow = GlowBlocks(tuple(lo), tuple(hi - lo), np.ones((1, 1, 1), bool))
        else:
            glow = glow_blocks(grid, tuple(extras), clipping)
        if glow is not None and simplify > 0:   # simplified block i's centre: i f + (f - 1) / 2
            f = 2.0 ** simplify
            glow = GlowBlocks(tuple((x - (f - 1.0) / 2.0) / f for x in glow.origin),
                              tuple(x / f for x in glow.side), glow.mask)
        medium = replace(medium, glow=glow)
    return medium


# A graph is evaluated on a lattice this many times finer per axis (Cycles evaluates its nodes on
# interpolated grid values; a finer lattice brings per-voxel evaluation closer to that) while the
# fine lattice stays within SUPERSAMPLE_VOXELS.
SUPERSAMPLE, SUPERSAMPLE_VOXELS = 2, 1 << 21


def _graph_medium(matrix_world, grid, graph: shading.ShaderGraph, label: str, notes: list[str],
                  simplify: int, clipping: float) -> Medium:
    """The medium of a node graph over the grid's lattice, evaluated later on the render thread
    (shading.ShaderSource): where Cycles' volume mesh is (the grids' leaf blocks, or a fluid
    domain's cube), every voxel's coefficients and emission. A graph that gives a medium where the
    grids are 0 (a Clamp's minimum, a constant emission) fills the whole of the leaf blocks, which
    reach up to 8 voxels beyond the grid's box: the lattice is widened to them (at full
    resolution; a simplified grid keeps its box)."""
    name = getattr(grid, "grid_name", "density")
    available = {name: grid.density, **grid.extras}
    grids = {n: available[n] for n in graph.grids if n in available}
    density, index_to_object = simplify_grid(grid.density, grid.index_to_object, simplify)
    grids = _simplify_extras(grids, simplify) if simplify > 0 else grids
    extras = tuple(n for n in graph.grids if n in grid.extras)
    glow = glow_blocks(grid, extras, clipping) if grid.bounds is None else None
    if glow is not None and simplify > 0:      # simplified block i's centre: i f + (f - 1) / 2
        f = 2.0 ** simplify
        glow = GlowBlocks(tuple((x - (f - 1.0) / 2.0) / f for x in glow.origin),
                          tuple(x / f for x in glow.side), glow.mask)
    pad = ((0, 0),) * 3
    if glow is not None and _fills_empty_voxels(graph):
        notes.append(f"{label}: its shader gives a medium where the grids are empty, up to Cycles' "
                     f"volume bounds (the grids' 8³ leaf blocks), whose edge is drawn at voxel "
                     f"resolution")
        if simplify == 0:
            lo, hi = glow.box
            before = np.maximum(0, -np.ceil(np.asarray(lo))).astype(np.int64)
            after = np.maximum(0, np.ceil(np.asarray(hi)).astype(np.int64) - np.asarray(density.shape))
            pad = tuple((int(x), int(y)) for x, y in zip(before, after, strict=True))
            shift = np.eye(4)
            shift[:3, 3] = -before
            index_to_object = index_to_object @ shift
            glow = GlowBlocks(tuple(o + b for o, b in zip(glow.origin, before, strict=True)), glow.side,
                              glow.mask)
    elif glow is None and grid.bounds is None:
        return None                                  # no voxel is active: Cycles renders nothing
    size = int(np.prod([n + a + b for n, (a, b) in zip(density.shape, pad, strict=True)]))
    factor = SUPERSAMPLE if size * SUPERSAMPLE ** 3 <= _supersample_budget(graph) else 1
    key = digest("graph", grid.key or id(grid.density), graph.key, simplify, float(clipping), factor)
    source = shading.ShaderSource(graph=graph, grids=grids, grid_shape=density.shape, key=key,
                                  index_to_object=index_to_object, pad=pad, bounds=glow,
                                  clip=(name, clipping) if clipping > 0.0 else None, supersample=factor,
                                  label=label)
    return shading.pending_medium(source, matrix_world)


def _fills_empty_voxels(graph: shading.ShaderGraph) -> bool:
    """Whether the graph gives extinction or emission where every grid it reads is 0."""
    if graph.reads_position:
        return True
    f = shading.evaluate(graph, {n: np.zeros(1, np.float32) for n in graph.grids}, 1)
    return bool((f.sigma_a + f.sigma_s).max() > 0.0 or f.emission.max() > 0.0)


def _supersample_budget(graph: shading.ShaderGraph) -> int:
    """Fine voxels a graph may be evaluated on: textures cost some 20 times more per voxel."""
    return SUPERSAMPLE_VOXELS // 8 if graph.reads_position else SUPERSAMPLE_VOXELS


LEAF = 8        # OpenVDB's leaf nodes: 8³ voxels, at indices that are multiples of 8
_glow_blocks = caches.memo("extract.glow blocks", 1)      # the last grid's (GlowBlocks)
_clipped = caches.memo("extract.clipped density", 1)      # the last grid's density within its blocks


def within_bounds(grid, extras: tuple[str, ...], clipping: float) -> np.ndarray:
    """The density as Cycles renders it under Volume ▸ Render ▸ Clipping: Cycles uses the clipping
    only to leave out of its volume mesh the 8³ leaf blocks where no voxel (grown by one) reaches it
    (``glow_blocks``), and renders every value inside the others, those below the clipping
    included. Zero outside those blocks (everywhere when no voxel reaches it). The last result is
    kept, like glow_blocks'."""
    key = (id(grid.density), grid.key, tuple(extras), float(clipping))
    hit = _clipped.get(key)
    if hit is not None and hit[0] is grid.density:
        return hit[1]
    d = np.asarray(grid.density)
    blocks = glow_blocks(grid, extras, clipping)
    if blocks is None:
        out = np.zeros_like(d)
    else:
        inside = blocks.mask
        for axis in range(3):
            inside = np.repeat(inside, LEAF, axis=axis)
        s = (-np.asarray(blocks.origin)).astype(np.int64)      # array index 0 in the blocks' voxels
        inside = inside[s[0]:s[0] + d.shape[0], s[1]:s[1] + d.shape[1], s[2]:s[2] + d.shape[2]]
        out = np.where(inside, d, np.zeros((), d.dtype))
    _clipped.put(key, (grid.density, out))
    return out


def glow_blocks(grid, extras: tuple[str, ...] = (), clipping: float = 0.0):
    """Where Cycles' volume mesh puts a volume, as GlowBlocks in the grid's array index space
    (voxel centres at integers): the 8³ leaf blocks, aligned on the file's voxel indices
    (``grid.first_index``), that hold an active voxel of the density or of the ``extras`` grids
    the material reads once the active voxels have grown by one to their face neighbours (Cycles
    pads the topology by a voxel for linear interpolation, then meshes the faces of the leaves
    that hold any: intern/cycles/scene/volume.cpp). A voxel is active where it is not 0 (the
    density: at least ``clipping``), as in files written from dense arrays. None when none is.
    The last result is kept, like simplify_grid's."""
    key = (id(grid.density), grid.key, tuple(extras), float(clipping))
    hit = _glow_blocks.get(key)
    if hit is not None and hit[0] is grid.density:
        return hit[1]
    active = np.asarray(grid.density) != 0.0
    if clipping > 0.0:
        active &= np.asarray(grid.density) >= clipping
    for name in extras:
        a = np.asarray(grid.extras[name])
        active |= (a != 0.0).any(axis=-1) if a.ndim == 4 else a != 0.0
    result = None
    if active.any():
        grown = np.pad(active, 1)                   # array index -1 at 0
        core = grown.copy()
        for axis in range(3):
            lead = [slice(None)] * 3
            lag = [slice(None)] * 3
            lead[axis], lag[axis] = slice(1, None), slice(None, -1)
            grown[tuple(lead)] |= core[tuple(lag)]
            grown[tuple(lag)] |= core[tuple(lead)]
        origin = np.asarray(grid.first_index, np.int64) - 1     # the file index of grown[0, 0, 0]
        before = origin % LEAF
        after = (-(before + np.asarray(grown.shape))) % LEAF
        aligned = np.pad(grown, [(int(b), int(a)) for b, a in zip(before, after, strict=True)])
        n = [s // LEAF for s in aligned.shape]
        blocks = aligned.reshape(n[0], LEAF, n[1], LEAF, n[2], LEAF).any(axis=(1, 3, 5))
        start = origin - before - np.asarray(grid.first_index)    # block (0, 0, 0) in array indices
        result = GlowBlocks(tuple(float(x) for x in start), float(LEAF), blocks)
    _glow_blocks.put(key, (grid.density, result))
    return result


def _simplify_extras(extras: dict, level: int) -> dict:
    """The attribute grids at the simplified density's resolution; the last ones are kept, like
    ``simplify_grid``'s, so that a viewport edit that keeps the grids does not redo them."""
    out = {}
    for name, a in extras.items():
        key = (id(a), level)
        hit = _simplified_extras.get(key)
        if hit is None or hit[0] is not a:
            small = _downsample_channels(a, 2 ** level)
            small.setflags(write=False)
            hit = _simplified_extras.put(key, (a, small))
        out[name] = hit[1]
    return out


def _downsample_channels(a: np.ndarray, f: int) -> np.ndarray:
    """A scalar (nx, ny, nz) or colour (nx, ny, nz, c) grid at 1/f of its resolution, as
    ``simplify_grid`` does the density."""
    if a.ndim == 3:
        return downsample(a, f)
    return np.stack([downsample(a[..., c], f) for c in range(a.shape[-1])], axis=-1)


def _fluid_medium(instance, frame: int, cache: GridCache, notes: list[str],
                  simplify: int = 0) -> Medium | None:
    """A Mantaflow gas domain, from its baked cache for ``frame``."""
    ob = instance.object
    label = f"Fluid domain '{_label(instance)}'"
    attributes = ("density", "flame", "heat", "temperature", "color")
    read = _sigma(meshes.first_material(ob), None, label, notes, attributes)
    try:
        grid, _all, warnings = fluid.read_domain(ob, frame, cache, tuple(read["grids"]), _label(instance))
    except VolumeReadError as ex:
        notes.append(f"{ex}; rendering without it")
        return None
    notes.extend(warnings)
    notes.extend(grid.warnings)
    if read["grid"] not in (None, "density"):
        notes.append(f"{label}: the material reads grid '{read['grid']}' as density; the domain's "
                     f"density is used")
    return _grid_medium(np.array(instance.matrix_world), grid, read, label, notes, simplify)


def _mesh_medium(instance, material, notes: list[str],
                 resolution: int = mesh_volume.DEFAULT_RESOLUTION,
                 arrays: _Arrays | None = None) -> Medium | None:
    """A mesh with a volume-only material: the medium inside its surface, a coverage grid
    voxelised once per shape (engine/mesh_volume.py) and placed by the instance's matrix.
    ``arrays``: the walk's triangles by evaluated mesh (shared by instances, kept across walks)."""
    ob = instance.object
    label = f"Object '{_label(instance)}'"
    read = _sigma(material, None, label, notes)
    if read["grid"] not in (None, "density"):
        # Principled Volume's Density Attribute ("density") reads 1 on a mesh, as in Cycles.
        notes.append(f"{label}: a mesh has no grid '{read['grid']}'; its medium has the material's "
                     f"constant density")
    arrays = WalkCache().walk() if arrays is None else arrays
    mesh = arrays.get(instance)     # instances of one mesh read its triangles once
    if mesh is None:
        notes.append(f"{label}: the mesh has no faces, so it holds no medium")
        return None
    if read.get("graph") is not None:
        return _mesh_graph_medium(instance, ob, mesh, read["graph"], label, notes, resolution)
    fields = _drop_missing(read["fields"], {}, label, notes, "is not rendered in a mesh medium")
    medium, mesh_notes = mesh_volume.mesh_medium(
        mesh[0], mesh[1], np.array(instance.matrix_world), resolution=resolution, label=label,
        **fields)
    notes.extend(mesh_notes)
    return medium


def _mesh_graph_medium(instance, ob, mesh, graph: shading.ShaderGraph, label: str, notes: list[str],
                       resolution: int) -> Medium | None:
    """A mesh medium whose material is a node graph: the graph over the voxelised inside
    (positions in object space, Generated from the mesh's texture space; a mesh has no grids, so
    Attribute nodes read 0 and the Density Attribute is ignored, as in Cycles), times the coverage
    of each voxel; evaluated on the render thread (shading.ShaderSource)."""
    occ = mesh_volume.occupancy_cache.get(mesh[0], mesh[1], resolution)
    if not occ.closed:
        notes.append(f"{label}: the mesh is not closed ({occ.open_edges} open edges); its medium fills "
                     f"what most of three axis-aligned views see inside")
    if not occ.coverage.any():
        notes.append(f"{label}: the mesh encloses no volume, so it holds no medium")
        return None
    data = ob.data
    if hasattr(data, "texspace_location") and hasattr(data, "texspace_size"):
        graph = replace(graph, texspace=(tuple(data.texspace_location), tuple(data.texspace_size)))
    coverage = occ.coverage
    factor = SUPERSAMPLE if coverage.size * SUPERSAMPLE ** 3 <= _supersample_budget(graph) else 1
    source = shading.ShaderSource(graph=graph, grids={}, grid_shape=coverage.shape,
                                  key=digest("mesh", occ.key, graph.key, factor),
                                  index_to_object=occ.index_to_object, coverage=coverage, supersample=factor,
                                  label=label)
    return shading.pending_medium(source, np.array(instance.matrix_world))
