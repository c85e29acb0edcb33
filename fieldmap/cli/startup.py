"""Start-up of ``fieldmap point``: Warp imported in a thread while the model is verified.

A one-point run of a degree-2190 model spends most of its wall time before the kernel runs:
``import warp`` (Python registering Warp's builtins: GIL-bound, ~0.3 s), the model and its
recursion tables verified against their SHA-256 (~190 MB; hashing releases the GIL) and the
coefficients transposed for the kernel (a NumPy copy, GIL released too). The import and the
model do not depend on each other, so :func:`load_model_early` starts a thread that imports
Warp and the point modules while the main thread loads the model and verifies the tables
(:func:`fieldmap.models.cache.prefetch_tables`); the thread then builds the kernel's struct
(:func:`fieldmap.field.sh.kernel_model`, cached there; on the CPU only) while the main
thread initialises Warp, and :meth:`Early.settle` waits for it before anything is computed.
Nothing is computed differently: the same modules, files, checks and struct, in another order.

Errors stay where they were. The thread swallows its own: a failed import is raised again by
the main thread's ``import`` (which waits for the thread's through Python's per-module import
locks), a bad device by the main thread's device check, a failed struct by the main thread's
own build. The model's error is raised by :meth:`Early.settle`, after the device check (the
former order). The thread is no daemon: an early exit waits for it (bounded work).
"""

from __future__ import annotations

import importlib
import threading
from typing import TYPE_CHECKING, Any, cast

if TYPE_CHECKING:
    from fieldmap.models.shmodel import SHModel

#: what the point path imports that needs Warp, heaviest first
_ENGINE_MODULES = (
    "warp",
    "fieldmap._warp",
    "fieldmap.field.gravity",
    "fieldmap.kernels.sh",
    "fieldmap.field.normal",
)
#: quantities evaluated with the struct of the model itself (geoid, anomaly and potential use
#: a disturbing model derived from it, the commission errors NumPy sums: for those, the
#: recursion tables only are loaded ahead)
_STRUCT_QUANTITIES = (
    "disturbance",
    "gravity",
    "gradient",
    "gradient-disturbance",
    "gradient-invariants",
)


class _Engine(threading.Thread):
    def __init__(self, device: str | None, quantity: str) -> None:
        super().__init__(name="fieldmap-engine", daemon=False)
        self.device, self.quantity = device, quantity
        self.model: Any = None  # an SHModel (fieldmap.models is not imported before it is needed)
        self.ready = threading.Event()  # set by the main thread: the model (or None) is known

    def run(self) -> None:
        try:
            for name in _ENGINE_MODULES:
                importlib.import_module(name)
            self.ready.wait()
            if self.model is None or self.quantity not in _STRUCT_QUANTITIES:
                return
            from fieldmap import _warp
            from fieldmap.field import sh

            device = _warp.resolve_device(self.device)
            if device == "cpu":  # a CUDA struct (device copies) is left to the main thread
                sh.kernel_model(self.model, device, points=True)
        except BaseException:  # noqa: BLE001 - the main thread meets and reports the same error
            pass


class Early:
    """The model loaded during Warp's import, or its error; :meth:`settle` hands it over."""

    def __init__(
        self,
        model: SHModel | None = None,
        failure: BaseException | None = None,
        engine: _Engine | None = None,
    ) -> None:
        self.model, self.failure, self.engine = model, failure, engine

    def settle(self) -> SHModel:
        """Raise the model's error, or wait for the thread's struct and return the model."""
        if self.failure is not None:
            raise self.failure
        if self.engine is not None:
            self.engine.join()
        # no model only from Early() (normal gravity, a table), which is never settled
        return cast("SHModel", self.model)


def load_model_early(
    model: str,
    options: dict[str, Any] | None,
    quantity: str,
    device: str | None = None,
    table: bool = False,
) -> Early:
    """Load the model while Warp is imported (and the kernel's struct built) in a thread.

    The model's error (bad file, degree, epoch) is kept for :meth:`Early.settle`, so that the
    caller checks the device first, as before. Nothing is started for ``--quantity normal`` and
    a compensation ``table`` (no spherical-harmonic model). ``options``: keywords of
    :func:`fieldmap.models.registry.load_model` (``lmax``, ``epoch``, ``model_dir``...).
    """
    if quantity == "normal" or table:
        return Early()
    from fieldmap.models.registry import load_model  # numpy and the readers, before the thread

    engine = _Engine(device, quantity)
    engine.start()
    try:
        sh_model = load_model(model, **(options or {}))
        if not quantity.endswith("-sigma"):  # the commission errors are NumPy sums: no tables
            from fieldmap.models import cache

            cache.prefetch_tables(sh_model.lmax)  # still under Warp's import, GIL released
        engine.model = sh_model  # the thread's struct then takes the prefetched tables
    except Exception as exc:  # noqa: BLE001 - raised by Early.settle after the device check
        return Early(failure=exc, engine=engine)
    finally:
        engine.ready.set()
    return Early(sh_model, engine=engine)
