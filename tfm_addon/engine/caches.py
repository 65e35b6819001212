"""What the add-on keeps between frames on the CPU side, in one registry: each memo a bounded map
from a content key to what was made from it (the least recently used dropped first), registered
by name with its bound. ``REGISTRY.clear()`` empties every memo and first runs what registered to
end with them (the Sky Texture bake's threads and timers): the add-on's unregister calls it, so
that an add-on registered again starts from nothing.

The GPU resources are not here: the renderer keeps them (``engine/renderer.py``, ``_Cache``) with
the GL context that owns them, on the one GL thread, and releases them with it.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable


class Memo:
    """A bounded map, least recently used dropped first; safe across threads."""

    def __init__(self, name: str, kept: int):
        self.name = name
        self.kept = max(int(kept), 1)
        self._items: OrderedDict = OrderedDict()
        self._lock = threading.RLock()

    def get(self, key: Hashable, default=None):
        """The value kept for ``key`` (now the most recently used), or ``default``."""
        with self._lock:
            if key not in self._items:
                return default
            self._items.move_to_end(key)
            return self._items[key]

    def put(self, key: Hashable, value):
        """Keep ``value`` for ``key``; returns it."""
        with self._lock:
            self._items[key] = value
            self._items.move_to_end(key)
            while len(self._items) > self.kept:
                self._items.popitem(last=False)
        return value

    def made(self, key: Hashable, make: Callable[[], object]):
        """The value kept for ``key``, or ``make()`` kept (made outside the lock: a slow build
        does not hold other threads; two threads may both make it, the last one kept)."""
        with self._lock:
            if key in self._items:
                self._items.move_to_end(key)
                return self._items[key]
        return self.put(key, make())

    def pop(self, key: Hashable, default=None):
        with self._lock:
            return self._items.pop(key, default)

    def clear(self) -> None:
        with self._lock:
            self._items.clear()

    def keys(self) -> list:
        """The keys kept, least recently used first (a copy)."""
        with self._lock:
            return list(self._items)

    def __contains__(self, key) -> bool:
        with self._lock:
            return key in self._items

    def __len__(self) -> int:
        with self._lock:
            return len(self._items)


class Registry:
    """Every memo by name, and what ends with them."""

    def __init__(self):
        self._memos: dict[str, Memo] = {}
        self._enders: list[Callable[[], None]] = []
        self._lock = threading.Lock()

    def memo(self, name: str, kept: int) -> Memo:
        """The memo ``name`` (made on first use with bound ``kept``)."""
        with self._lock:
            if name not in self._memos:
                self._memos[name] = Memo(name, kept)
            return self._memos[name]

    def on_clear(self, end: Callable[[], None]) -> None:
        """Call ``end()`` (once registered, whatever the calls) before the memos are emptied."""
        with self._lock:
            if end not in self._enders:
                self._enders.append(end)

    def clear(self) -> None:
        """End what registered to end (each in turn, every one called even if one fails), then
        empty every memo."""
        with self._lock:
            enders = list(self._enders)
            memos = list(self._memos.values())
        failures = []
        for end in enders:
            try:
                end()
            except Exception as ex:       # noqa: BLE001 - the others still end; raised below
                failures.append(ex)
        for memo in memos:
            memo.clear()
        if failures:
            raise failures[0]

    def sizes(self) -> dict[str, int]:
        """Entries kept per memo."""
        with self._lock:
            return {name: len(m) for name, m in self._memos.items()}


REGISTRY = Registry()


def memo(name: str, kept: int) -> Memo:
    """``REGISTRY.memo``: the module-level way to keep something between frames."""
    return REGISTRY.memo(name, kept)
