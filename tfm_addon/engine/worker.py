"""A thread that owns a Renderer and its GL context, so hosts can call it from any thread.

Two kinds of work reach the thread:

- jobs in a first-in first-out queue (``submit``, ``call``, ``render``): final renders, probes;
- latest-wins slots (``post``): a newer request in a slot replaces the one waiting there (which
  is dropped without running) and cancels the one running (it stops at its next cancel check,
  between passes). A slot job may be a generator: the thread runs it one step (one ``yield``)
  at a time and serves the queue between steps, so an accumulating viewport never holds up a
  final render.

The host never waits without a bound: ``Job.wait`` takes a timeout, ``call`` and ``render``
poll their job in short waits, and ``close`` fails every waiting and queued job at once with
``WorkerClosed``. Callbacks a host passes (``cancel``, ``progress``) run on the thread that
called ``render``, never on the GL thread.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable
from types import GeneratorType

from .errors import RenderCancelled, RendererError
from .output import RenderOutput
from .renderer import Renderer
from .scene import RenderSettings, Scene

OPEN, CLOSING, CLOSED = "open", "closing", "closed"
POLL_S = 0.02  # how often a waiting host thread looks at its cancel and progress callbacks
HANDSHAKE_S = 1.0  # the longest the GL thread waits for a host's answer between passes
STOP_WAIT_S = 5.0  # the longest a waiter leaving without a result waits for its cancelled job to stop


class WorkerClosed(RendererError):
    """The render worker is closing or closed: the job did not run (or did not finish)."""


class Job:
    """One piece of work for the GL thread. ``fn(renderer, job)`` runs there; it may check
    ``job.cancelled`` (or pass it to the renderer as its cancel callable) and report
    ``job.set_progress(fraction)``. The host waits with ``wait``/``result`` (bounded)."""

    def __init__(self, fn: Callable, slot: str | None = None):
        self.fn = fn
        self.slot = slot
        self.started = False
        self._cancel = threading.Event()
        self._done = threading.Event()
        self._result = None
        self._error: BaseException | None = None
        self._generator: GeneratorType | None = None
        self._progress: list[float] = []
        self._lock = threading.Lock()
        self._cond = threading.Condition(self._lock)
        self.lockstep = False   # a host thread answers check_in() (see wait_for)
        self._asking = False

    # -- GL thread side
    def cancelled(self) -> bool:
        """True once the host cancelled this job, a newer one superseded it or the worker closes."""
        return self._cancel.is_set()

    def check_in(self) -> bool:
        """The renderer's cancel callable: with a host waiting in lockstep, hand it the progress
        so far and wait (at most HANDSHAKE_S) for it to ask its own cancel callback; else just
        ``cancelled()``. Each pass of a final render is thus checked on the host's thread."""
        if self.lockstep and not self._cancel.is_set():
            with self._cond:
                self._asking = True
                self._cond.notify_all()
                self._cond.wait_for(lambda: not self._asking or self._cancel.is_set(), HANDSHAKE_S)
                self._asking = False
        return self._cancel.is_set()

    def set_progress(self, fraction: float) -> None:
        with self._cond:
            self._progress.append(float(fraction))
            self._cond.notify_all()

    def _finish(self, result=None, error: BaseException | None = None) -> bool:
        with self._cond:
            if self._done.is_set():
                return False  # already failed by close(): the late result is dropped
            self._result, self._error = result, error
            self._done.set()
            self._cond.notify_all()
            return True

    # -- host side
    def cancel(self) -> None:
        with self._cond:
            self._cancel.set()
            self._cond.notify_all()

    def _wait_event(self, timeout_s: float) -> tuple[bool, bool]:
        """Wait for the end, a question or progress; (ended, asked)."""
        with self._cond:
            self._cond.wait_for(lambda: self._done.is_set() or self._asking or self._progress, timeout_s)
            return self._done.is_set(), self._asking

    def _answer(self) -> None:
        with self._cond:
            self._asking = False
            self._cond.notify_all()

    @property
    def done(self) -> bool:
        return self._done.is_set()

    def wait(self, timeout_s: float | None) -> bool:
        """Wait at most ``timeout_s`` seconds; True when the job has ended."""
        return self._done.wait(timeout_s)

    def take_progress(self) -> list[float]:
        """The progress fractions reported since the last call, oldest first."""
        with self._lock:
            out, self._progress = self._progress, []
        return out

    def result(self, timeout_s: float | None = None):
        """The job's return value; raises its error, WorkerClosed, or TimeoutError after
        ``timeout_s`` seconds (None: until the job ends, which close() guarantees)."""
        if not self._done.wait(timeout_s):
            raise TimeoutError(f"the render worker did not finish the job within {timeout_s} s")
        if self._error is not None:
            raise self._error
        return self._result


class RenderWorker:
    """Runs every renderer call on one dedicated thread (an EGL context is current on the
    thread that made it, and must not displace the host's own GL context).

    ``stats`` counts 'jobs' (run to the end), 'steps' (generator steps), 'dropped' (slot jobs
    superseded before they ran), 'superseded' (slot jobs cancelled while running)."""

    def __init__(self, renderer_factory: Callable[[], Renderer] = Renderer):
        self._cond = threading.Condition()
        self._state = OPEN
        self._queue: deque[Job] = deque()
        self._slots: dict[str, Job] = {}
        self._stale: list[Job] = []     # started generators to close on the GL thread
        self._running: Job | None = None
        self.stats = {"jobs": 0, "steps": 0, "dropped": 0, "superseded": 0}
        self._factory = renderer_factory
        self._thread = threading.Thread(target=self._run, name="tfm-gl", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ GL thread
    def _run(self) -> None:
        renderer = None
        try:
            renderer = self._factory()
            while True:
                with self._cond:
                    while self._state == OPEN and not (self._queue or self._slots or self._stale):
                        self._cond.wait()
                    stale, self._stale = self._stale, []
                    if self._state != OPEN:
                        stale += self._take_all()
                        job = None
                    elif self._queue:
                        job = self._queue.popleft()
                    elif self._slots:
                        slot = next(iter(self._slots))
                        job = self._slots.pop(slot)
                    else:
                        job = None
                    self._running = job
                for old in stale:
                    self._close_generator(old)
                if job is None:
                    if self._state != OPEN:
                        return
                    continue
                more = self._step(job, renderer)
                with self._cond:
                    self._running = None
                    if more:
                        if job.cancelled() or self._state != OPEN or job.slot in self._slots:
                            self._stale.append(job)
                        else:
                            self._slots[job.slot] = job   # next step after the queue's jobs
        except BaseException as exc:  # the renderer could not start: every waiter hears why
            with self._cond:
                self._state = CLOSING
                jobs = self._take_all()
            for job in jobs:
                job._finish(error=exc)
        finally:
            try:
                if renderer is not None:
                    renderer.release()
            finally:
                with self._cond:
                    self._state = CLOSED
                    jobs = self._take_all()
                    self._cond.notify_all()
                for job in jobs:
                    self._close_generator(job)

    def _take_all(self) -> list[Job]:
        """Empty the queue and the slots (lock held)."""
        jobs = [*self._queue, *self._slots.values(), *self._stale]
        self._queue.clear()
        self._slots.clear()
        self._stale = []
        return jobs

    def _step(self, job: Job, renderer: Renderer) -> bool:
        """Run the job (or its generator's next step); True when a generator has more steps."""
        job.started = True
        try:
            if job.cancelled():
                raise RenderCancelled("The job was cancelled before it ran.")
            if job._generator is None:
                value = job.fn(renderer, job)
                if not isinstance(value, GeneratorType):
                    self.stats["jobs"] += 1
                    job._finish(result=value)
                    return False
                job._generator = value
            next(job._generator)
            self.stats["steps"] += 1
            return True
        except StopIteration as stop:
            self.stats["jobs"] += 1
            job._finish(result=stop.value)
        except BaseException as exc:  # handed to the host
            job._finish(error=exc)
        return False

    def _close_generator(self, job: Job) -> None:
        if job._generator is not None:
            try:
                job._generator.close()
            except Exception:  # noqa: S110 - a generator failing in its cleanup has nobody to tell
                pass
        job._finish(error=WorkerClosed("The job was dropped.") if self._state != OPEN
                    else RenderCancelled("A newer request superseded this one."))

    # ------------------------------------------------------------------ host side
    def _closed_error(self) -> WorkerClosed:
        return WorkerClosed("The TFM render worker is closed (the add-on was disabled or Blender "
                            "is shutting down); nothing was rendered.")

    def submit(self, fn: Callable) -> Job:
        """Queue ``fn(renderer, job)``; returns its Job at once. Raises WorkerClosed."""
        job = Job(fn)
        with self._cond:
            if self._state != OPEN:
                raise self._closed_error()
            self._queue.append(job)
            self._cond.notify_all()
        return job

    def post(self, slot: str, fn: Callable) -> Job:
        """Latest wins: ``fn(renderer, job)`` replaces the job waiting in ``slot`` (dropped, never
        run) and cancels the one running in it. ``fn`` may return a generator (run step by step)."""
        job = Job(fn, slot=slot)
        with self._cond:
            if self._state != OPEN:
                raise self._closed_error()
            old = self._slots.pop(slot, None)
            if old is not None:
                old.cancel()
                if old.started:
                    self._stale.append(old)
                else:
                    self.stats["dropped"] += 1
                    old._finish(error=RenderCancelled("A newer request superseded this one."))
            running = self._running
            if running is not None and running.slot == slot and not running.cancelled():
                running.cancel()
                self.stats["superseded"] += 1
            self._slots[slot] = job
            self._cond.notify_all()
        return job

    def call(self, fn: Callable[[Renderer], object], timeout_s: float | None = None):
        """Run ``fn(renderer)`` on the GL thread and return its result (or raise its error).
        Raises WorkerClosed when the worker closes first, TimeoutError after ``timeout_s``."""
        job = self.submit(lambda renderer, job: fn(renderer))
        return job.result(timeout_s)

    def render(self, scene: Scene, settings: RenderSettings | None = None,
               cancel: Callable[[], bool] | None = None,
               progress: Callable[[float], None] | None = None, passes: bool = True,
               samples: int = 1, client: str = "final", **sampling) -> RenderOutput:
        """Renderer.render on the GL thread (``samples`` > 1: the mean of that many antialiasing
        samples, sampling.render_samples). ``cancel`` and ``progress`` are called on the calling
        thread while it waits (every POLL_S seconds); a true ``cancel()`` stops the render at the
        renderer's next check (between passes) and raises RenderCancelled. ``client``: the
        renderer's cache client ('final', 'preview', ...); ``sampling``: render_samples' ``until``
        and ``whites`` (a tile of a frame, tiles.py)."""
        from .sampling import render_samples

        def fn(r, job):
            if samples <= 1:
                return r.render(scene, settings, job.check_in, job.set_progress, passes, client=client)
            return render_samples(r, scene, settings, samples, job.check_in, job.set_progress, passes,
                                  client=client, **sampling)

        return wait_for(self.submit(fn), cancel, progress)

    @property
    def counters(self) -> dict:
        return self.call(lambda r: dict(r.counters), timeout_s=60.0)

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    @property
    def closing(self) -> bool:
        return self._state != OPEN

    def close(self, timeout_s: float = 10.0) -> bool:
        """Stop taking work, fail every queued job and the running one's waiters with
        WorkerClosed, cancel the running job, and wait up to ``timeout_s`` for the thread to
        release the GL context and end. True when it ended; otherwise it ends by itself after
        its current pass (it takes no new work)."""
        with self._cond:
            if self._state == OPEN:
                self._state = CLOSING
            jobs = [*self._queue, *(j for j in self._slots.values() if not j.started)]
            self._queue.clear()
            for slot in [s for s, j in self._slots.items() if not j.started]:
                del self._slots[slot]
            running = self._running
            self._cond.notify_all()
        error = self._closed_error()
        for job in jobs:
            job.cancel()
            job._finish(error=error)
        if running is not None:
            running.cancel()
            running._finish(error=error)
        if threading.current_thread() is self._thread:
            return False
        self._thread.join(timeout_s)
        return not self._thread.is_alive()


def wait_for(job: Job, cancel: Callable[[], bool] | None = None,
             progress: Callable[[float], None] | None = None, poll_s: float = POLL_S):
    """Wait for ``job`` on the calling thread and return its result, calling ``progress`` with
    each fraction it reported and ``cancel()`` each time the job checks in (``Job.check_in``,
    between passes; a true value cancels it). Waits in steps of ``poll_s`` seconds. A waiter
    that stops waiting without a result (Ctrl+C's KeyboardInterrupt, an error in a callback)
    cancels the job first and waits up to STOP_WAIT_S for it to stop (the GL thread stops it at
    its next check instead of finishing a frame nobody will read), so that the exception goes on
    with the GL thread idle, not rendering while the host unwinds or exits."""
    job.lockstep = cancel is not None
    try:
        while True:
            ended, asked = job._wait_event(poll_s)
            if progress is not None:
                for fraction in job.take_progress():
                    progress(fraction)
            else:
                job.take_progress()
            if ended:
                return job.result(0)
            if asked:  # the GL thread finished a pass and waits: ask here, on the host's thread
                if cancel is not None and not job.cancelled() and cancel():
                    job.cancel()
                job._answer()
    except BaseException:
        if not job.done:
            job.cancel()
            job.wait(STOP_WAIT_S)   # a second Ctrl+C here ends the wait, the job stays cancelled
        raise
