"""Blender's generic panels opened to the TFM engine.

A panel whose ``COMPAT_ENGINES`` holds 'BLENDER_RENDER' is Blender's way of saying "any engine
that renders Blender's data": Cycles, EEVEE and Workbench show those. TFM shows them all (the
Physics tab, particles, mesh data, textures, the view layer, Simplify, ...) except the panels of
``EXCLUDED``, each with what TFM does not honour, and also opens the few EEVEE-only panels of
``EEVEE_PANELS`` whose settings it reads. ``open_panels`` adds 'TFM' to those panels'
``COMPAT_ENGINES`` and remembers exactly what it changed; ``close_panels`` undoes that and
nothing else, so enabling and disabling the add-on leaves Blender's panels as they were.

Panels registered after the add-on (by add-ons enabled later) are not opened.
"""

from __future__ import annotations

import bpy

ENGINE = 'TFM'
GENERIC = 'BLENDER_RENDER'

# Generic panels TFM keeps closed: name -> what TFM does not honour (and what replaces it).
EXCLUDED: dict[str, str] = {
    "DATA_PT_light": "shows only the light type; DATA_PT_EEVEE_light replaces it (type, colour, "
                     "temperature, power and exposure, which TFM reads)",
    "NODE_DATA_PT_light": "the Shader Editor's copy of DATA_PT_light; NODE_DATA_PT_EEVEE_light "
                          "replaces it",
    "OBJECT_PT_visibility": "shows ray visibility to EEVEE only; TFM_PT_object_visibility shows "
                            "what TFM honours (renders, camera and shadow rays, holdout)",
    "DATA_PT_context_lightprobe": "light probes capture EEVEE's indirect light; TFM renders "
                                  "single scattering and reads no probe",
    "DATA_PT_lightprobe": "light probe settings (EEVEE's indirect light)",
    "DATA_PT_lightprobe_display": "light probe display (EEVEE's indirect light)",
    "DATA_PT_lightprobe_parallax": "light probe parallax (EEVEE's indirect light)",
    "DATA_PT_lightprobe_visibility": "light probe visibility (EEVEE's indirect light)",
    "RENDER_PT_stereoscopy": "stereoscopy: TFM renders every view from the camera's centre",
    "RENDER_PT_output_views": "stereoscopic output formats (TFM renders no stereo pair)",
    "DATA_PT_camera_stereoscopy": "camera interocular distance and convergence (no stereo pair)",
}

# EEVEE-only panels whose settings TFM reads: name -> what it reads there.
EEVEE_PANELS: dict[str, str] = {
    "DATA_PT_EEVEE_light": "light type, colour, temperature, power, exposure, Normalize, the size "
                           "(radius, angle, shape and size: soft shadows)",
    "NODE_DATA_PT_EEVEE_light": "the same in the Shader Editor",
    "MATERIAL_PT_preview": "material previews (the engine renders them)",
    "EEVEE_MATERIAL_PT_context_material": "material slots",
    "EEVEE_MATERIAL_PT_surface": "the surface shader (Principled or Diffuse BSDF colour)",
    "EEVEE_MATERIAL_PT_volume": "the volume shader (scattering, absorption, anisotropy, density)",
}

# (panel, what its own COMPAT_ENGINES was: a set, or None when it inherited it) for the panels
# that were given a copy of a set shared with an excluded panel; and the sets 'TFM' was added to.
_copied: list[tuple[type, set | None]] = []
_extended: list[set] = []


def registered_panels() -> list[type]:
    """Every registered Panel class, each once (subclasses of subclasses included)."""
    found: dict[type, None] = {}
    stack = list(bpy.types.Panel.__subclasses__())
    while stack:
        panel = stack.pop()
        if panel in found:
            continue
        found[panel] = None
        stack.extend(panel.__subclasses__())
    return [p for p in found if getattr(p, "is_registered", False)]


def generic_panels() -> list[type]:
    """The registered panels open to 'BLENDER_RENDER'."""
    return [p for p in registered_panels()
            if isinstance(getattr(p, "COMPAT_ENGINES", None), set) and GENERIC in p.COMPAT_ENGINES]


def panels_to_open() -> list[type]:
    """The generic panels not excluded, and the EEVEE panels TFM reads."""
    chosen = [p for p in generic_panels() if p.__name__ not in EXCLUDED]
    for name in EEVEE_PANELS:
        panel = getattr(bpy.types, name, None)
        if panel is not None and isinstance(getattr(panel, "COMPAT_ENGINES", None), set):
            chosen.append(panel)
    return chosen


def open_panels() -> int:
    """Add 'TFM' to the chosen panels' COMPAT_ENGINES; returns how many panels were opened."""
    if _extended or _copied:
        close_panels()
    chosen = panels_to_open()
    kept_closed = {id(p.COMPAT_ENGINES) for p in registered_panels()
                   if p.__name__ in EXCLUDED and isinstance(getattr(p, "COMPAT_ENGINES", None), set)}
    opened = 0
    for panel in chosen:
        engines = panel.COMPAT_ENGINES
        if ENGINE in engines:
            continue
        if id(engines) in kept_closed:
            # The set is shared with an excluded panel: give this panel its own copy.
            _copied.append((panel, panel.__dict__.get("COMPAT_ENGINES")))
            panel.COMPAT_ENGINES = set(engines) | {ENGINE}
        else:
            engines.add(ENGINE)
            _extended.append(engines)
        opened += 1
    return opened


def close_panels() -> None:
    """Undo ``open_panels``: remove exactly the 'TFM' entries it added."""
    while _copied:
        panel, own = _copied.pop()
        if own is None:
            del panel.COMPAT_ENGINES
        else:
            panel.COMPAT_ENGINES = own
    while _extended:
        _extended.pop().discard(ENGINE)
