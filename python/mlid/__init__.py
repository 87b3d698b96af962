"""mlid: maximum-likelihood identification of aircraft stability and control
derivatives (NASA CR-2200 and beyond).  The numerics live in the Fortran core
(mlid._core); this package holds the objects, I/O, command line and plots."""

from .openmp import brief_spin as _brief_spin

#: The spin count mlid chose for the core's waiting OpenMP threads, None when
#: the environment chose or it was too late (openmp.py; before the core loads).
OPENMP_SPIN = _brief_spin()

from ._version import installed_version as _installed_version
from .heap import keep_freed_memory as _keep_freed_memory
from .errors import (MlidError, InputError, SingularInformationError, DivergenceError,
                     NonConvergenceError, InternalError, MlidWarning)
from .model import LinearModel, LongitudinalModel, UserModel, X22Model, EquationModel, SixDofModel, \
    FlightPathModel
from .data import FlightData
from .result import FitResult, whiteness
from .reduction import reduce_measured_state, reduced_data, recover_disturbance
from .fit import fit
from .evaluate import evaluate, frequency_evaluate
from .simulate import simulate
from .monte_carlo import monte_carlo
from .options import default_options
from .jacobians import check_jacobians
from .deck import read_deck, run_deck
from .analysis import fpe, compare_models, predict
from .design import InputDesign, DesignedInput
from .parallel import monte_carlo_parallel
from .diagnose import diagnose
from .validate import validate, Validation
from .fourier import fourier_transform, recursive_frequency_fit
from .frequency import (FrequencyResponse, TransferFunctionFit, record_response, model_response,
                        fit_transfer_function)



__version__ = _installed_version()
#: Whether freed memory is kept for the next fit (heap.py; MLID_MALLOC=system: not).
KEEPS_FREED_MEMORY = _keep_freed_memory()

__all__ = ["MlidError", "InputError", "SingularInformationError", "DivergenceError",
           "NonConvergenceError", "InternalError", "MlidWarning", "LinearModel", "LongitudinalModel", "UserModel",
           "X22Model", "EquationModel", "SixDofModel", "FlightPathModel", "InputDesign", "DesignedInput", "monte_carlo_parallel", "diagnose", "check_jacobians", "FlightData", "FitResult",
           "fit", "evaluate", "simulate", "monte_carlo", "default_options", "read_deck",
           "run_deck", "whiteness", "reduce_measured_state", "reduced_data",
           "recover_disturbance", "fpe", "compare_models", "predict", "validate", "Validation",
           "FrequencyResponse", "TransferFunctionFit", "record_response", "model_response",
           "fit_transfer_function", "fourier_transform", "frequency_evaluate",
           "recursive_frequency_fit"]
