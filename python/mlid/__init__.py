"""mlid: maximum-likelihood identification of aircraft stability and control
derivatives (NASA CR-2200 and beyond).  The numerics live in the Fortran core
(mlid._core); this package holds the objects, I/O, command line and plots.

The package is in layers, each a subpackage; a module imports its own layer
and those below it only (tests/test_layers.py checks it):

    cli          decks, campaigns, the ``mlid`` command
    report       plots, the HTML report, reference fits, validation
    discrepancy  what the model is missing (diagnose and its tools)
    design, frequency, online, export
                 input design, simulation, Monte Carlo; frequency responses,
                 Fourier transforms; online estimation; export to a simulator
                 (siblings: none imports another)
    estimate     options, evaluate, fit, its result and results table
    model, data  model objects and manoeuvres; flight records
    _bridge      the only module that imports the extension mlid._core
    base         errors, checks, files, heap, openmp, progress, _version: small
                 helpers at the top of the package, below everything else

This file, at the top, gathers the public names.
"""

from .openmp import brief_spin as _brief_spin

#: The spin count mlid chose for the core's waiting OpenMP threads, None when
#: the environment chose or it was too late (openmp.py; before the core loads).
OPENMP_SPIN = _brief_spin()

from ._version import installed_version as _installed_version
from .heap import keep_freed_memory as _keep_freed_memory
from .errors import (MlidError, InputError, SingularInformationError, DivergenceError,
                     NonConvergenceError, InternalError, OutOfMemoryError, MlidWarning)
from .data.flight_data import FlightData
from .model.models import LinearModel, LongitudinalModel, UserModel, X22Model, EquationModel, \
    SixDofModel, FlightPathModel
from .model.jacobians import check_jacobians
from .estimate.options import default_options
from .estimate.evaluate import evaluate, frequency_evaluate
from .estimate.fit import fit
from .estimate.result import FitResult, whiteness
from .estimate.stepwise import stepwise, stepwise_candidates, ModelStructure
from .estimate.table_fit import fit_tables, TableFit, fit_global, GlobalTableFit
from .frequency.fourier import fourier_transform, recursive_frequency_fit
from .frequency.smoothing import smooth, deriv
from .frequency.responses import (FrequencyResponse, TransferFunctionFit, record_response,
                                  model_response, fit_transfer_function)
from .design.simulate import simulate
from .design.monte_carlo import monte_carlo
from .design.parallel import monte_carlo_parallel
from .design.input_design import InputDesign, DesignedInput
from . import online
from . import export
from .discrepancy.reduction import reduce_measured_state, reduced_data, recover_disturbance
from .discrepancy.model_checks import fpe, compare_models, predict
from .discrepancy.diagnose import diagnose
from .report.validation import validate, Validation
from .cli.deck import read_deck, run_deck

# Module paths the README documented before the layers, still reachable as
# mlid.core.input_signal, mlid.campaign, mlid.compatibility, mlid.plots and
# mlid.reference.
from . import core
from .cli import campaign
from .estimate import compatibility
from .report import plots, reference

def __getattr__(name):
    """mlid.__version__, looked up when asked (the package metadata's import
    is a fifth of `import mlid`)."""
    if name == "__version__":
        return _installed_version()
    raise AttributeError(f"module 'mlid' has no attribute {name!r}")
#: Whether freed memory is kept for the next fit (heap.py; MLID_MALLOC=system: not).
KEEPS_FREED_MEMORY = _keep_freed_memory()

__all__ = ["MlidError", "InputError", "SingularInformationError", "DivergenceError",
           "NonConvergenceError", "InternalError", "OutOfMemoryError", "MlidWarning", "LinearModel", "LongitudinalModel", "UserModel",
           "X22Model", "EquationModel", "SixDofModel", "FlightPathModel", "InputDesign", "DesignedInput", "monte_carlo_parallel", "diagnose", "check_jacobians", "FlightData", "FitResult",
           "fit", "evaluate", "simulate", "monte_carlo", "default_options", "read_deck",
           "run_deck", "whiteness", "reduce_measured_state", "reduced_data",
           "recover_disturbance", "fpe", "compare_models", "predict", "validate", "Validation",
           "FrequencyResponse", "TransferFunctionFit", "record_response", "model_response",
           "fit_transfer_function", "fourier_transform", "frequency_evaluate",
           "recursive_frequency_fit", "smooth", "deriv", "stepwise", "stepwise_candidates",
           "ModelStructure", "fit_tables", "TableFit", "fit_global", "GlobalTableFit"]
