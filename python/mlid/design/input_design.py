"""Optimal input design for linear models (report §VII-VIII): thin wrappers
over fortran/design/mlid_design.f90.

    d = mlid.InputDesign(F, G, H, R, ["f(1,1)", "f(1,2)", "g(1,1)"])
    mu = d.mu_max(T=4.0)                       # operator method (eq. 7.39)
    T = d.critical_length(mu, "riccati")      # or "transition" (eqs 7.25-7.34)
    inp = d.optimal_input(T=4.0, energy=311)  # u(t), M, det M, sigma, ...

R is the spectral density of the continuous measurement noise (eq. 7.11).
"""


import numpy as np

from .._bridge import api as _api, call_handle, put, results, lines
from ..checks import real_array, whole
from ..errors import InputError, check_status, guarded, guarded_class
from ..model.calls import _set_model_with_params
from ..model.models import LinearModel



@guarded
def summary(M):
    """What the report tabulates for an information matrix (§8.1).

    Parameters
    ----------
    M : array_like (n, n)
        An information matrix.

    Returns
    -------
    dict
        ``trace``, ``det``, ``eigenvalues`` (ascending), ``trace_product``
        tr M tr M^-1, ``sigma`` (Cramer-Rao: sqrt of diag M^-1) and
        ``spread`` (largest over smallest eigenvalue).  A singular M (an
        unknown the input does not reach) gives det 0, infinite
        trace_product and spread, and sigma from the pseudo-inverse
        (infinite where M's diagonal is zero).

    Raises
    ------
    InputError
        If M is not square.
    """
    M = real_array("M", M)
    if M.ndim != 2 or M.shape[0] != M.shape[1]:
        raise InputError(f"M must be a square information matrix, got shape {M.shape}")
    eig = np.linalg.eigvalsh(M)
    if eig[0] <= 1e-13 * eig[-1]:               # an unknown the input does not reach
        sigma = np.where(np.diag(M) > 0, np.sqrt(np.diag(np.linalg.pinv(M))), np.inf)
        return {"trace": float(np.trace(M)), "det": 0.0, "eigenvalues": eig,
                "trace_product": np.inf, "sigma": sigma, "spread": np.inf}
    inv = np.linalg.inv(M)
    return {"trace": float(np.trace(M)), "det": float(np.linalg.det(M)), "eigenvalues": eig,
            "trace_product": float(np.trace(M) * np.trace(inv)),
            "sigma": np.sqrt(np.diag(inv)), "spread": float(eig[-1] / eig[0])}


class DesignedInput:
    """An input on [0, T] held over equal cells, and its information.

    Parameters
    ----------
    t_edges : ndarray (cells + 1,)
        Cell edges, 0 to T.
    u : ndarray (cells, nu)
        The input on each cell.
    M : ndarray (n, n)
        Its (unweighted) information matrix; ``summary`` holds
        ``summary(M)``.
    mu : float, optional
        The design operator's eigenvalue, for energy-optimal inputs.
    energy : float, optional
        The integral of u'u over [0, T] (default: computed from u).
    weights : ndarray, optional
        The weights of the unknowns it was designed for.
    """

    def __init__(self, t_edges, u, M, mu=None, energy=None, weights=None):
        self.t_edges, self.u, self.M, self.mu = t_edges, u, M, mu
        self.energy = float(np.sum(u**2) * (t_edges[1] - t_edges[0])) if energy is None else energy
        self.weights = weights
        self.summary = summary(M)

    @property
    def t(self):
        """Cell midpoints."""
        return 0.5 * (self.t_edges[1:] + self.t_edges[:-1])

    def spectrum(self):
        """The magnitude of the first input's Fourier transform (Fig. 8.4), zero-padded
        eightfold.

        Returns
        -------
        omega : ndarray
            Frequencies [rad/s].
        magnitude : ndarray
            ``|U(omega)|``.
        """
        dt = self.t_edges[1] - self.t_edges[0]
        n = 8 * len(self.u)                      # zero padding for a smooth curve
        spec = np.abs(np.fft.rfft(self.u[:, 0], n)) * dt
        return 2 * np.pi * np.fft.rfftfreq(n, dt), spec


class _OfModel:
    """F, G or H of a design: the block of its linear model (an array view:
    changed in place or set anew, the model changes with it)."""

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, design, owner=None):
        return self if design is None else getattr(design._model, self.name)

    def __set__(self, design, value):
        setattr(design._model, self.name, value)


@guarded_class
class InputDesign:
    """The linear model x' = F x + G u (+ Gamma eta), z = H x + n
    (E{n n'} = R delta) and the unknowns, elements of F, G or H named
    'f(i,j)', 'g(i,j)', 'h(i,j)'.  process_noise: Gamma Q Gamma' (nx x nx);
    the design then uses the steady-state Kalman filter's sensitivities
    (§7.5, eq. 7.84).

    Parameters
    ----------
    F : array_like (nx, nx)
    G : array_like (nx, nu)
    H : array_like (ny, nx)
    R : array_like (ny, ny)
        Spectral density of the continuous measurement noise (eq. 7.11).
    unknowns : list of str
        The parameters the input is designed for: 'f(i,j)', 'g(i,j)',
        'h(i,j)', 1-based.
    weights : array_like, optional
        One per unknown (default ones): the design maximises tr(W M).
    process_noise : array_like (nx, nx), optional
        Gamma Q Gamma' (default none).

    Raises
    ------
    InputError
        Matrices that do not fit together, unknowns that are not elements of
        F, G or H or are listed twice, weights not one per unknown.
    """

    F, G, H = _OfModel(), _OfModel(), _OfModel()

    def __init__(self, F, G, H, R, unknowns, weights=None, process_noise=None):
        F, G, H, self.R = (np.asfortranarray(np.atleast_2d(real_array(n, a)))
                           for n, a in (("F", F), ("G", G), ("H", H), ("R", R)))
        nx, ny = F.shape[0], H.shape[0]
        if F.shape != (nx, nx) or G.shape[0] != nx or H.shape[1] != nx or self.R.shape != (ny, ny):
            raise InputError(f"F {F.shape}, G {G.shape}, H {H.shape} and R "
                             f"{self.R.shape} do not fit together")
        if isinstance(unknowns, str):
            raise InputError("unknowns must be a list of names such as ['f(1,1)', 'g(2,1)']")
        self.unknowns = list(unknowns)
        # the elements by name, read and checked by the core (mlid_design_unknowns)
        self._unk = {"unknowns": "".join(f"{name}\n" for name in self.unknowns)}
        self.weights = np.ones(len(self.unknowns)) if weights is None else \
            np.asarray(weights, dtype=float)
        if self.weights.shape != (len(self.unknowns),):
            raise InputError(f"weights: one per unknown ({len(self.unknowns)})")
        self.process_noise = np.zeros((nx, nx)) if process_noise is None else \
            np.asfortranarray(np.asarray(process_noise, dtype=float))
        if self.process_noise.shape != (nx, nx):
            raise InputError(f"process_noise must be {nx}x{nx} (Gamma Q Gamma')")
        self._model = LinearModel(F, G, H)
        check_status(*_api.mlid_design_check(self._call()))

    def _call(self, **given):
        """This thread's handle (its value) with the design in it, as
        fortran/api/mlid_api_design.f90 takes it: the linear model and its
        parameters, then R, the process noise, the unknowns, their weights and
        the call's given values by name."""
        h = call_handle()
        _set_model_with_params(h, self._model)
        put(h, r=self.R, gq=self.process_noise, w=self.weights, **self._unk, **given)
        return h.value

    def with_weights(self, weights):
        """The same design problem with other weights.

        Parameters
        ----------
        weights : array_like
            One per unknown.

        Returns
        -------
        InputDesign
        """
        return InputDesign(self.F, self.G, self.H, self.R, self.unknowns, weights,
                           self.process_noise)

    def with_model(self, F=None, G=None, H=None):
        """The same unknowns, R, weights and process noise for other matrices.

        Parameters
        ----------
        F, G, H : array_like, optional
            Replacements (default: the design's own).

        Returns
        -------
        InputDesign
        """
        return InputDesign(self.F if F is None else F, self.G if G is None else G,
                           self.H if H is None else H, self.R, self.unknowns, self.weights,
                           self.process_noise)

    @staticmethod
    def _cells(cells):
        return whole("cells", cells, 4, 10**6)     # the core bounds cells x inputs too

    def _cells_input(self, u):
        """u as (cells, nu), one row per cell (a vector for one input)."""
        u = real_array("u", u)
        nu = self._model.nu
        u = u.reshape(-1, 1) if u.ndim == 1 and nu == 1 else u
        if u.ndim != 2 or u.shape[1] != nu:
            raise InputError(f"u has shape {u.shape}; expected (cells, {nu}), one row per cell")
        return u

    def _check_t(self, T, what="T"):
        if isinstance(T, (str, bytes)) or not (np.isfinite(T) and T > 0):
            raise InputError(f"{what} must be > 0, got {T}")

    def mu_max(self, T, cells=200, method="operator"):
        """The largest eigenvalue mu of the design operator on [0, T]:
        max tr(WM) = mu E.

        Parameters
        ----------
        T : float
            Length of the input [s], > 0.
        cells : int
            Input cells of the operator method (4 or more).
        method : {'operator', 'riccati'}
            'operator': eq. 7.39 on cells and 2*cells input cells,
            Richardson-extrapolated; 'riccati': the secant of eq. 7.89 on the
            Riccati critical length, started from the operator's value +-0.1%
            (near mu's supremum over T, a wider bracket has no conjugate
            point).

        Returns
        -------
        float

        Raises
        ------
        InputError
            T not > 0, bad cells or method, matrices the core refuses (R not
            positive definite, weights not > 0, values not finite).
        SingularInformationError
            The unknowns do not affect the outputs.
        NonConvergenceError
            With process noise, the steady-state filter did not converge;
            'riccati', the secant did not.
        """
        self._check_t(T)
        cells = self._cells(cells)
        mu, u, status, msg = _api.mlid_design_mu(self._call(), t=float(T), ncell=cells,
                                                  nu=self._model.nu)
        check_status(status, msg)
        if method == "operator":
            return float(mu)
        if method != "riccati":
            raise InputError(f"method must be 'operator' or 'riccati', got {method!r}")
        mu2, status, msg = _api.mlid_design_mu_for_length(self._call(), td=float(T), mu0=mu)
        check_status(status, msg)
        return float(mu2)

    _SOLVERS = {"riccati": 1, "transition": 2}

    def _solver(self, method):
        if method not in self._SOLVERS:
            raise InputError(f"method must be one of {', '.join(map(repr, self._SOLVERS))}, got "
                             f"{method!r}")
        return self._SOLVERS[method]

    def critical_length(self, mu, method="riccati", tmax=100.0):
        """The interval length T whose largest eigenvalue is mu (the first
        conjugate point).

        Parameters
        ----------
        mu : float
            The eigenvalue, > 0.
        method : {'riccati', 'transition'}
            'riccati' (eqs 7.31-7.34, §7.7) or 'transition' (eqs 7.25-7.29).
        tmax : float
            The longest T searched.

        Returns
        -------
        float or (float, ndarray)
            T; with 'transition', (T, lambda(0)) (the costate's start, for
            ``optimal_input``).

        Raises
        ------
        InputError
            mu not > 0, an unknown method.
        NonConvergenceError
            No conjugate point up to tmax.
        """
        if not mu > 0:
            raise InputError(f"mu must be > 0, got {mu}")
        na = (len(self.unknowns) + 1) * self._model.nx
        tmax, solver = float(tmax), self._solver(method)
        T, lam0, status, msg = _api.mlid_design_length(self._call(), mu=float(mu), tmax=tmax,
                                                       method=solver, na=na)
        check_status(status, msg)
        return (float(T), lam0) if method == "transition" else float(T)

    def information(self, T, u):
        """The (unweighted) information matrix of an input held over equal
        cells of [0, T] (eq. 7.12).

        Parameters
        ----------
        T : float
            Length of the input [s], > 0.
        u : array_like (cells, nu)
            The input on each cell (a vector for one input).

        Returns
        -------
        ndarray (n, n)
            Over the unknowns, in their order.

        Raises
        ------
        InputError
            T not > 0, u not one row per cell.
        """
        self._check_t(T)
        u = self._cells_input(u)
        M, status, msg = _api.mlid_design_information(self._call(), t=float(T), ncell=len(u),
                                                       nu=u.shape[1], u=u.ravel(),
                                                       m=len(self.unknowns))
        check_status(status, msg)
        return M

    def optimal_input(self, T, energy, cells=200, method="operator"):
        """The input on [0, T] of the given energy that maximises tr(W M).

        Parameters
        ----------
        T : float
            Length [s], > 0.
        energy : float
            The integral of u'u over [0, T], > 0.
        cells : int
            Input cells.
        method : {'operator', 'transition'}
            'operator': the design operator's eigenvector on 2*cells cells;
            'transition': u = -G_A' lambda/mu from lambda(0) of the
            transition-matrix method, on cells cells.

        Returns
        -------
        DesignedInput

        Raises
        ------
        InputError
            T or energy not > 0, bad cells or method.
        SingularInformationError
            The unknowns do not affect the outputs.
        NonConvergenceError
            'transition': no conjugate point; with process noise, the
            steady-state filter did not converge.
        """
        self._check_t(T)
        self._check_t(energy, "energy")
        cells = self._cells(cells)
        nu = self._model.nu
        mu, u, status, msg = _api.mlid_design_mu(self._call(), t=float(T), ncell=cells, nu=nu)
        check_status(status, msg)
        if method == "transition":
            Tc, lam0 = self.critical_length(mu, "transition", tmax=10 * T)
            u, status, msg = _api.mlid_design_input(self._call(), mu=mu, t=float(T), lam0=lam0,
                                                    ncell=cells, nu=nu)
            check_status(status, msg)
        elif method != "operator":
            raise InputError(f"method must be 'operator' or 'transition', got {method!r}")
        u = u.reshape(-1, nu) * np.sqrt(energy)
        edges = np.linspace(0.0, T, len(u) + 1)
        return DesignedInput(edges, u, self.information(T, u), mu=float(mu), energy=energy,
                             weights=self.weights.copy())

    def amplitude_limited(self, T, peak, min_width):
        """The best square wave under ``|u| <= peak`` with no pulse shorter than
        min_width: tr(WM) is convex in u, so the optimum over the box is a
        corner (+-peak on every cell); found by local search from the signs
        of the leading energy-optimal inputs (fortran/design/mlid_design.f90).  The
        cells are the widest that fit T at least min_width each.

        Parameters
        ----------
        T : float
            Length [s], > 0.
        peak : float
            The amplitude limit, > 0.
        min_width : float
            The shortest pulse [s], > 0 and not longer than T.

        Returns
        -------
        DesignedInput

        Raises
        ------
        InputError
            T, peak or min_width not > 0, or min_width longer than T.
        SingularInformationError
            The unknowns do not affect the outputs.
        """
        self._check_t(T)
        self._check_t(peak, "peak")
        self._check_t(min_width, "min_width")
        cells = int(np.floor(T / min_width + 1e-9))
        if cells < 1:
            raise InputError(f"min_width {min_width} is longer than T = {T}")
        nu = self._model.nu
        u, trwm, status, msg = _api.mlid_design_amplitude(self._call(), t=float(T), ncell=cells,
                                                          peak=float(peak), nu=nu)
        check_status(status, msg)
        u = u.reshape(-1, nu)
        edges = np.linspace(0.0, T, cells + 1)
        return DesignedInput(edges, u, self.information(T, u), weights=self.weights.copy())

    def equalised(self, T, energy, iterations=12, alpha=1.0, cells=200):
        """The weighted-trace design of §7.8: weights updated by eq. 7.88,
        w <- w + alpha (1/m_ii - w), toward an equal diagonal of W M, alpha
        halved whenever the ratio of its largest to smallest element does not
        fall (the core's, fortran/design/mlid_design.f90, which deck designs use).

        Parameters
        ----------
        T, energy, cells
            As for ``optimal_input``.
        iterations : int
            Weight updates tried.
        alpha : float
            The first step of the update.

        Returns
        -------
        design : DesignedInput
            The best design found (its ``weights`` the ones it used).
        ratios : list of float
            The ratio of the largest to the smallest element of diag(W M)
            of each design accepted, the first the starting one.

        Raises
        ------
        InputError
            As for ``optimal_input``.
        """
        self._check_t(T)
        self._check_t(energy, "energy")
        iterations = whole("iterations", iterations, 0, 10**4)
        if not (np.isfinite(alpha) and alpha > 0):
            raise InputError(f"alpha must be > 0, got {alpha}")
        cells = self._cells(cells)
        check_status(*_api.mlid_design_equalised(self._call(), t=float(T), ncell=cells,
                                                 e=float(energy), iterations=iterations,
                                                 alpha=float(alpha)))
        r = results(call_handle())
        u = r["u"].reshape(-1, self._model.nu)
        best = DesignedInput(np.linspace(0.0, T, len(u) + 1), u, r["mm"], mu=r["mu"],
                             energy=energy, weights=r["w"].copy())
        return best, [float(x) for x in r["ratios"]]

    #: The candidates rank_inputs compares by default (the core's names).
    CANDIDATES = tuple(lines(_api.mlid_name_list("ranking_candidates")))   # the core's

    def rank_inputs(self, T, energy=None, peak=None, candidates=CANDIDATES, cells=200,
                    rank_by="det", f_band=None, pulse_width=None):
        """Which input to fly: candidate inputs held over ``cells`` equal cells
        of [0, T], each scaled to the same energy (or peak), ranked by the
        information they give the unknowns (fortran/design/mlid_input_ranking.f90,
        as the deck's ``&design candidates``).

        'optimal' is ``optimal_input(T, energy, cells // 2)`` (the design
        operator's eigenfunction, with this design's weights); 'doublet',
        '3211', 'multisine', 'sweep' (linear), 'log_sweep' and 'prbs' come
        from the signal library.  With several inputs the multisine drives
        them all at once (mutually orthogonal), the other shapes one after
        the other in equal windows of T.  The band and base pulse not given
        come from the model: w_max the largest eigenvalue modulus of F, band
        [1/T, w_max/pi] Hz, doublet and 3211 base pulse 2.33/w_max (the
        doublet's spectral peak at the fastest mode), shortened to fit.

        Parameters
        ----------
        T : float
            Length [s], > 0.
        energy, peak : float
            The common energy (the integral of u'u over [0, T]) or the common
            peak (the largest absolute value of u): give one.
        candidates : sequence of str
            Names from ``CANDIDATES``.
        cells : int
            Even, 4 or more: the cells every candidate is held over.
        rank_by : {'det', 'trace'}
            D-optimal (det M, the default) or tr M.
        f_band : (float, float), optional
            The multisine's and the sweeps' band [Hz] (default: the model's).
        pulse_width : float, optional
            The doublet's and the 3211's base pulse [s] (default: the model's).

        Returns
        -------
        InputRanking
            Best first; ``to_frame()``, a text repr, ``mlid.plots.input_ranking``.

        Raises
        ------
        InputError
            T not > 0, neither or both of energy and peak, an unknown
            candidate or rank_by, cells odd or out of range, a band above
            the cells' Nyquist frequency.
        """
        from .input_ranking import InputRanking
        self._check_t(T)
        if (energy is None) == (peak is None):
            raise InputError("give one of energy and peak: the level every candidate is "
                             "scaled to")
        compare, level = ("energy", energy) if peak is None else ("peak", peak)
        self._check_t(level, compare)
        if isinstance(candidates, str):
            raise InputError("candidates must be a list of names such as ['optimal', "
                             "'doublet']")
        band = np.zeros(2) if f_band is None else real_array("f_band", f_band)
        if band.shape != (2,):
            raise InputError(f"f_band must be (f_min, f_max) in Hz, got shape {band.shape}")
        pw = 0.0 if pulse_width is None else pulse_width
        if isinstance(pw, (str, bytes)) or not (np.isfinite(pw) and pw > 0 or pw == 0.0):
            raise InputError(f"pulse_width must be > 0, got {pulse_width}")
        cells = whole("cells", cells, 4, 100000)
        h = self._call(candidates="".join(f"{c}\n" for c in candidates), compare=compare,
                       rank_by=str(rank_by), f_band=band, pulse_width=float(pw))
        check_status(*_api.mlid_design_rank(h, t=float(T), ncell=cells, level=float(level)))
        return InputRanking(results(call_handle()), self.unknowns, T, compare, level,
                            str(rank_by).lower(), self._model.nu)

    # -- the state-limit penalty of §7.6 ----------------------------------
    def _penalty(self, penalty=None):
        """The state penalty K of §7.6 for the core (zero: none)."""
        nx = self._model.nx
        if penalty is None:
            return np.zeros((nx, nx), order="F")
        K = real_array("penalty", penalty)
        K = np.diag(K) if K.ndim == 1 else K          # one weight per state
        if K.shape != (nx, nx):
            raise InputError(f"penalty: one weight per state ({nx}) or an {nx}x{nx} matrix, "
                             f"got shape {K.shape}")
        return np.asfortranarray(K)

    def state_penalised(self, T, energy, penalty, cells=200):
        """The input on [0, T] of the given energy that maximises
        tr(W M) - int x' K x dt: the state-limit penalty of §7.6 (x the
        model's states under the input from x(0) = 0).  The criterion is
        still a quadratic form in u; mu is the largest eigenvalue of the
        penalised operator, so mu * energy is the penalised criterion.

        Parameters
        ----------
        T, energy, cells
            As for ``optimal_input``.
        penalty : array_like (nx,) or (nx, nx)
            K: one weight per state (diagonal) or a symmetric matrix >= 0,
            in units of the information per state unit squared per second.

        Returns
        -------
        DesignedInput
            Its ``mu`` the penalised eigenvalue, ``M`` the (unpenalised)
            information, ``state_penalty`` K.

        Raises
        ------
        InputError
            As for ``optimal_input``; K not nx x nx, not symmetric, not >= 0;
            a penalty that outweighs the information of every input.
        """
        self._check_t(T)
        self._check_t(energy, "energy")
        K = self._penalty(penalty)
        cells = self._cells(cells)
        mu, u, status, msg = _api.mlid_design_mu(self._call(kx=K), t=float(T), ncell=cells,
                                                  nu=self._model.nu)
        check_status(status, msg)
        u = u.reshape(-1, self._model.nu) * np.sqrt(energy)
        edges = np.linspace(0.0, T, len(u) + 1)
        inp = DesignedInput(edges, u, self.information(T, u), mu=float(mu), energy=energy,
                            weights=self.weights.copy())
        inp.state_penalty = K
        return inp

    def penalised_length(self, mu, penalty, method="riccati", tmax=100.0):
        """``critical_length`` of the criterion with the state penalty K
        (``state_penalised``): the T whose largest penalised eigenvalue is mu.

        Parameters
        ----------
        mu, method, tmax
            As for ``critical_length``.
        penalty : array_like (nx,) or (nx, nx)
            As for ``state_penalised``.

        Returns
        -------
        float or (float, ndarray)
            As for ``critical_length``.

        Raises
        ------
        InputError, NonConvergenceError
            As for ``critical_length``; a bad penalty.
        """
        if not mu > 0:
            raise InputError(f"mu must be > 0, got {mu}")
        na = (len(self.unknowns) + 1) * self._model.nx
        K = self._penalty(penalty)
        tmax, solver = float(tmax), self._solver(method)
        T, lam0, status, msg = _api.mlid_design_length(self._call(kx=K), mu=float(mu), tmax=tmax,
                                                       method=solver, na=na)
        check_status(status, msg)
        return (float(T), lam0) if method == "transition" else float(T)

    def response(self, T, u, substeps=4):
        """The model's states under an input held over equal cells of [0, T],
        from x(0) = 0, exact at ``substeps`` points per cell.

        Parameters
        ----------
        T : float
            Length [s], > 0.
        u : array_like (cells, nu)
            The input on each cell (a vector for one input).
        substeps : int
            Samples per cell (even: ``state_integral`` uses Simpson's rule).

        Returns
        -------
        t : ndarray (cells * substeps + 1,)
        x : ndarray (cells * substeps + 1, nx)

        Raises
        ------
        InputError
            T not > 0, u not one row per cell, substeps not >= 1.
        """
        self._check_t(T)
        u = self._cells_input(u)
        ns = whole("substeps", substeps, 1, 1000)
        x, status, msg = _api.mlid_design_response(f=self.F, g=self.G, t=float(T), ncell=len(u),
                                                   ns=ns, u=u.ravel())
        check_status(status, msg)
        return np.linspace(0.0, T, len(u) * ns + 1), x.T

    def state_integral(self, T, u):
        """int_0^T x x' dt of the model's states under the input (Simpson's
        rule on four exact samples per cell): the excursions the penalty of
        ``state_penalised`` weighs, int x' K x dt = sum(K * state_integral).

        Parameters
        ----------
        T, u
            As for ``response``.

        Returns
        -------
        ndarray (nx, nx)
        """
        t, x = self.response(T, u, substeps=4)
        w = np.ones(len(t))
        w[1:-1:2], w[2:-1:2] = 4.0, 2.0
        w *= (t[1] - t[0]) / 3.0
        return np.einsum("k,ki,kj->ij", w, x, x)
