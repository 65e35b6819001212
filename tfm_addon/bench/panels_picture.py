"""A picture of the add-on's panels, drawn from their real layout (docs/panels.png).

Each panel's ``draw`` (and ``draw_header``) runs against ``RecordingLayout``, which stands in for
Blender's ``UILayout`` (background Blender has no interface to take a screenshot of) and records
the rows it is asked for: every property with its label and current value, labels, boxes, and
whether the row is active. The rows are then drawn with matplotlib in the colours of Blender's
default theme. A small scene is rendered once first, so that the Volumes panel lists what Auto
chose for it.

    .venv/bin/python -m tfm_addon.bench.panels_picture [--out docs/panels.png]
"""

from __future__ import annotations

import argparse
import os
import tempfile
from dataclasses import dataclass
from types import SimpleNamespace

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@dataclass
class Row:
    """One thing a panel drew: a property ('prop', with ``name``), a 'label' or a 'search' field
    or an 'id' template (an ID pointer with New/Open)."""

    kind: str
    text: str
    name: str = ""
    value: object = None
    rna: object = None          # the property's bl_rna definition
    active: bool = True
    box: int = 0                # how many boxes it sits in
    split: bool = True          # drawn with the label in a column of its own
    expand: bool = False

    @property
    def key(self) -> str:
        """The property's identifier, or 'label:<text>' for a label."""
        return "label:" + self.text if self.kind == "label" else self.name


class RecordingLayout:
    """Records what a panel's draw() asks of Blender's UILayout; each drawn property must exist."""

    def __init__(self, rows: list[Row], parent: RecordingLayout | None = None, box: int = 0):
        self.rows, self.parent, self._box = rows, parent, box
        self.use_property_split = parent.use_property_split if parent else False
        self.use_property_decorate = False
        self.active = self.enabled = True
        self.alignment = 'EXPAND'

    def _is_active(self) -> bool:
        return self.active and self.enabled and (self.parent is None or self.parent._is_active())

    def column(self, *args, **kwargs) -> RecordingLayout:
        return RecordingLayout(self.rows, self, self._box)

    row = split = column

    def box(self) -> RecordingLayout:
        return RecordingLayout(self.rows, self, self._box + 1)

    def _add(self, kind, data, name, text, **kwargs) -> None:
        assert name in data.bl_rna.properties, f"{data!r} has no property {name!r}"
        rna = data.bl_rna.properties[name]
        label = rna.name if text is None else text
        self.rows.append(Row(kind, label, name, getattr(data, name), rna, self._is_active(), self._box,
                             self.use_property_split, **kwargs))

    def prop(self, data, name, text=None, expand=False, **kwargs) -> None:
        self._add("prop", data, name, text, expand=expand)

    def prop_search(self, data, name, search_data, search_name, text=None, **kwargs) -> None:
        assert search_name in search_data.bl_rna.properties
        self._add("search", data, name, text)

    def template_ID(self, data, name, **kwargs) -> None:
        self._add("id", data, name, "")

    def label(self, text="", **kwargs) -> None:
        self.rows.append(Row("label", text, active=self._is_active(), box=self._box))

    def separator(self, **kwargs) -> None:
        pass


def record(panel, context, method: str = "draw") -> list[Row]:
    """The rows ``panel.draw`` (or ``draw_header``) draws in ``context``."""
    rows: list[Row] = []
    getattr(panel, method)(SimpleNamespace(layout=RecordingLayout(rows)), context)
    return rows


# Blender's default theme (Properties editor).
BACKGROUND, PANEL, HEADER, FIELD, MENU = "#303030", "#3d3d3d", "#3d3d3d", "#545454", "#282828"
TEXT, DIM, SELECTED, BOX = "#e6e6e6", "#8a8a8a", "#4772b3", "#363636"
ROW_H, COL_W, PAD = 24, 360, 10


def _value_text(row: Row) -> str:
    rna, value = row.rna, row.value
    if rna.type == 'ENUM':
        return next(i.name for i in rna.enum_items if i.identifier == value)
    if rna.type == 'INT':
        return f"{value} px" if rna.subtype == 'PIXEL' else str(value)
    if rna.type == 'FLOAT':
        return f"{value:.3f}" if rna.subtype == 'FACTOR' else f"{value:.2f}"
    return str(value)


def _draw_rows(ax, rows: list[Row], x: float, y: float, width: float) -> float:
    from matplotlib.patches import FancyBboxPatch, Rectangle

    def field(x0, w, colour, text="", align="center", colour_text=TEXT, selected=False):
        ax.add_patch(FancyBboxPatch((x0, y + 3), w, ROW_H - 6, boxstyle="round,pad=0,rounding_size=4",
                                    fc=SELECTED if selected else colour, ec="#1f1f1f", lw=0.6))
        tx = {"center": x0 + w / 2, "left": x0 + 6, "right": x0 + w - 6}[align]
        ax.text(tx, y + ROW_H / 2, text, color=colour_text, fontsize=8, ha=align, va="center")

    split = x + 0.4 * width
    box_top = None
    for row in rows:
        inset = 8 * row.box
        if row.box and box_top is None:
            box_top = y
        colour = TEXT if row.active else DIM
        x0, w0 = x + inset, width - 2 * inset
        if row.kind == "label":
            ax.text(x0 + 8, y + ROW_H / 2, row.text, color=colour, fontsize=8, va="center")
        elif row.kind == "id":
            field(x0 + 4, w0 - 8, FIELD, "New      Open", colour_text=colour)
        elif row.rna.type == 'BOOLEAN':
            ax.add_patch(Rectangle((split + 4, y + 6), 12, 12, fc=SELECTED if row.value else FIELD,
                                   ec="#1f1f1f", lw=0.6))
            if row.value:
                ax.text(split + 10, y + ROW_H / 2, "✓", color="white", fontsize=8, ha="center", va="center")
            ax.text(split + 22, y + ROW_H / 2, row.text, color=colour, fontsize=8, va="center")
        else:
            ax.text(split - 6, y + ROW_H / 2, row.text, color=colour, fontsize=8, ha="right", va="center")
            fx, fw = split, x + width - split - 6 - inset
            if row.rna.type == 'ENUM' and row.expand:
                items = list(row.rna.enum_items)
                for k, item in enumerate(items):
                    field(fx + k * fw / len(items), fw / len(items), FIELD, item.name, colour_text=colour,
                          selected=item.identifier == row.value)
            elif row.rna.type == 'ENUM':
                field(fx, fw, MENU, _value_text(row) + "   ⌄", align="left", colour_text=colour)
            elif row.rna.type == 'FLOAT' and getattr(row.rna, "subtype", "") in ('COLOR', 'COLOR_GAMMA'):
                rgb = [min(max(float(c), 0.0), 1.0) ** (1 / 2.2) for c in list(row.value)[:3]]
                field(fx, fw, tuple(rgb))
            elif row.kind == "search":
                field(fx, fw, FIELD, str(row.value), align="left", colour_text=colour)
            else:
                field(fx, fw, FIELD, _value_text(row), colour_text=colour)
        y += ROW_H
        if box_top is not None and (row is rows[-1] or not rows[rows.index(row) + 1].box):
            ax.add_patch(FancyBboxPatch((x + 4, box_top + 1), width - 8, y - box_top,
                                        boxstyle="round,pad=0,rounding_size=4", fc="none", ec="#4a4a4a",
                                        lw=0.8))
            box_top = None
    return y


def draw_column(ax, title: str, panels: list[tuple], x: float, top: float) -> float:
    """One Properties editor tab: ``panels`` as (panel class, context, depth) from the top."""
    from matplotlib.patches import FancyBboxPatch

    ax.text(x + 4, top + 12, title, color=TEXT, fontsize=10, fontweight="bold", va="center")
    y = top + 30
    for panel, context, depth in panels:
        indent = 10 * depth
        x0, w = x + indent, COL_W - indent
        rows = record(panel, context)
        header = record(panel, context, "draw_header") if hasattr(panel, "draw_header") else []
        height = ROW_H + 4 + ROW_H * len(rows) + (6 if rows else 0)
        ax.add_patch(FancyBboxPatch((x0, y), w, height, boxstyle="round,pad=0,rounding_size=5",
                                    fc=PANEL if depth == 0 else BOX, ec="#262626", lw=0.8))
        tx = x0 + 10
        ax.text(tx, y + ROW_H / 2 + 2, "▾", color=TEXT, fontsize=8, va="center")
        tx += 14
        for row in header:     # a checkbox in the header, as Blender draws draw_header's
            ax.text(tx + 6, y + ROW_H / 2 + 2, "✓" if row.value else "", color="white", fontsize=8,
                    ha="center", va="center",
                    bbox=dict(boxstyle="square,pad=0.25", fc=SELECTED if row.value else FIELD, ec="#1f1f1f"))
            tx += 18
        ax.text(tx, y + ROW_H / 2 + 2, panel.bl_label, color=TEXT, fontsize=9, va="center")
        y = _draw_rows(ax, rows, x0, y + ROW_H + 4, w) + (6 if rows else 0) + 4
    return y


def scene_context(directory: str):
    """A small smoke scene with a spot, rendered once under Auto; the panels' context."""
    import bpy

    from .. import scenes
    from ..blender import scene_builder

    bpy.ops.wm.read_homefile(use_empty=True)
    made = scene_builder.build(scenes.smoke_scene(width=96, height=54, n=24), directory)
    scene = bpy.context.scene
    scene.render.engine = 'TFM'
    bpy.ops.render.render()
    scene.tfm.samples = 16        # as the README's first picture renders
    background = scene.world.node_tree.nodes.get("Background")
    if background is not None:
        background.inputs["Color"].default_value = (0.05, 0.05, 0.05, 1.0)     # Blender's default world
    return SimpleNamespace(engine='TFM', scene=scene, light=made["lights"][0].data, world=scene.world,
                           volume=made["medium"].data)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=os.path.join(ROOT, "docs", "panels.png"))
    args = parser.parse_args(argv)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import tfm_addon
    from tfm_addon.ui import panels as p

    tfm_addon.register()
    context = scene_context(tempfile.mkdtemp(prefix="tfm_panels_"))
    custom = SimpleNamespace(**vars(context))
    columns = [
        ("Render Properties", [(p.TFM_PT_sampling, context, 0), (p.TFM_PT_light_paths, context, 0),
                               (p.TFM_PT_volumes, context, 0), (p.TFM_PT_volume_shadows, context, 1),
                               (p.TFM_PT_performance, context, 0)]),
        ("Volumes, Quality: Custom", [(p.TFM_PT_volumes, custom, 0), (p.TFM_PT_volume_shadows, custom, 1)]),
        ("Object Data ▸ Light (a spot)",
         [(p.TFM_PT_light, context, 1), (p.TFM_PT_light_texture, context, 1)]),
        ("World", [(p.TFM_PT_world, context, 0), (p.TFM_PT_world_lighting, context, 1)]),
    ]
    width, height = len(columns) * (COL_W + 2 * PAD) + PAD, 700
    fig = plt.figure(figsize=(width / 100, height / 100), dpi=100)
    ax = fig.add_axes([0, 0, 1, 1])
    ax.set_xlim(0, width)
    ax.set_ylim(height, 0)
    ax.axis("off")
    fig.patch.set_facecolor(BACKGROUND)
    bottom = 0.0
    for k, (title, panels) in enumerate(columns):
        if title.startswith("Volumes"):
            context.scene.tfm.quality = 'CUSTOM'
        bottom = max(bottom, draw_column(ax, title, panels, PAD + k * (COL_W + 2 * PAD), PAD))
        context.scene.tfm.quality = 'AUTO'
    ax.set_ylim(bottom + PAD, 0)
    fig.set_size_inches(width / 100, (bottom + PAD) / 100)
    fig.savefig(args.out, dpi=100, facecolor=BACKGROUND)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
