"""The one registry of what the add-on keeps between frames (engine/caches.py): bounded memos,
least recently used dropped first, all emptied by one call after what ends with them; and no
module of the add-on keeps a cache of its own beside it."""

import ast
from pathlib import Path

import pytest

from tfm_addon.engine import caches

ROOT = Path(__file__).resolve().parents[1] / "tfm_addon"

# Module-level containers that hold state, not memos (each says what it holds).
STATE = {
    ("blender/final_render.py", "_stop"): "the signal handlers a final render installed",
    ("blender/final_render.py", "_job"): "the render job in progress",
    ("blender/viewport.py", "_polled"): "the live viewport sessions",
    ("blender/sky_bake.py", "_running"): "the bake threads running (ended with the memos)",
    ("blender/background.py", "_threads"): "background threads (ended with the memos)",
    ("blender/background.py", "_processes"): "child processes (killed with the memos)",
    ("blender/background.py", "_timers"): "Blender timers (unregistered with the memos)",
    ("blender/final_render.py", "last_messages"): "the last render's report, for the interface",
    ("blender/final_render.py", "last_timings"): "the last render's stage times, for the interface",
    ("blender/final_render.py", "auto_choices"): "what Auto chose per scene, for the interface",
    ("blender/final_render.py", "_preview_reported"): "the warnings a preview gave once",
    ("blender/panel_compat.py", "_copied"): "the panels registration changed (undone on unregister)",
    ("blender/panel_compat.py", "_extended"): "the panel sets registration extended",
    ("__init__.py", "_unregister_steps"): "what unregister undoes",
    ("engine/shading.py", "EVALUATIONS"): "a counter of graph evaluations, for tests",
    ("engine/scene.py", "HASHED"): "a counter of bytes hashed into keys, for tests",
}


def test_a_memo_keeps_the_most_recently_used():
    memo = caches.Memo("test", 2)
    memo.put("a", 1)
    memo.put("b", 2)
    assert memo.get("a") == 1          # a is now the most recent
    memo.put("c", 3)
    assert "b" not in memo and memo.get("a") == 1 and memo.get("c") == 3 and len(memo) == 2
    made = []
    assert memo.made("d", lambda: made.append(1) or 4) == 4
    assert memo.made("d", lambda: made.append(1) or 5) == 4 and made == [1]


def test_the_registry_ends_its_work_then_empties_every_memo():
    registry = caches.Registry()
    memo = registry.memo("one", 4)
    assert registry.memo("one", 8) is memo
    seen = []

    def end():
        seen.append(len(memo))          # the memos are still there when the work ends
        memo.put("late", 1)             # what a thread stores as it ends is emptied too

    def fails():
        raise RuntimeError("stuck")

    registry.on_clear(fails)
    registry.on_clear(end)
    registry.on_clear(end)              # once
    memo.put("k", 1)
    with pytest.raises(RuntimeError):
        registry.clear()
    assert seen == [1] and registry.sizes() == {"one": 0}


def _module_containers(tree: ast.Module):
    """Module-level names bound to an empty container or to a call of a container type."""
    for node in tree.body:
        targets, value = [], None
        if isinstance(node, ast.Assign):
            targets, value = node.targets, node.value
        elif isinstance(node, ast.AnnAssign) and node.value is not None:
            targets, value = [node.target], node.value
        for target in targets:
            if not isinstance(target, ast.Name):
                continue
            empty_literal = isinstance(value, ast.Dict | ast.List | ast.Set) and not (
                getattr(value, "keys", None) or getattr(value, "elts", None))
            container_call = (isinstance(value, ast.Call) and isinstance(value.func, ast.Name)
                              and value.func.id in {"dict", "OrderedDict", "set", "list", "Counter",
                                                    "defaultdict", "WeakValueDictionary"})
            if empty_literal or container_call:
                yield target.id
        if isinstance(node, ast.FunctionDef):
            for deco in node.decorator_list:
                name = deco.func if isinstance(deco, ast.Call) else deco
                text = ast.unparse(name)
                if text.endswith(("lru_cache", "functools.cache", "cache")):
                    yield f"@{text} {node.name}"


def test_no_module_keeps_a_cache_beside_the_registry():
    found = []
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel.startswith("bench/"):
            continue                    # the benchmark's scripts are not the add-on
        for name in _module_containers(ast.parse(path.read_text())):
            if (rel, name) not in STATE:
                found.append(f"{rel}: {name}")
    assert found == [], "module-level caches outside engine/caches.py: " + ", ".join(found)
