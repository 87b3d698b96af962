"""The core's wrappers were this one module; they are now split by what they
do (options, calls, evaluate, colored, fit, simulate, monte_carlo, signals,
jacobians).  Their names stay reachable here for the tests, benchmarks and
cases until those import the new modules."""

from ._bridge import api as _api, text as _text  # noqa: F401
from .colored import colored_covariance  # noqa: F401
from .evaluate import evaluate, frequency_evaluate  # noqa: F401
from .fit import fit  # noqa: F401
from .jacobians import check_jacobians  # noqa: F401
from .monte_carlo import monte_carlo  # noqa: F401
from .options import default_options, evaluate_options, options_by_name  # noqa: F401
from .signals import input_signal  # noqa: F401
from .simulate import simulate  # noqa: F401
