"""A six-degree-of-freedom model (``SixDofModel``), the longitudinal kind
written as equations (``LongitudinalModel.with_tables``), or a fit of
either, as JSBSim's aerodynamics: an ``<aerodynamics>`` section, or a
minimal aircraft around it.

JSBSim works in English units (FGJSBBase): lengths in ft, areas in ft^2,
mass in slug (weights in lbs), forces in lbf, dynamic pressure in lbf/ft^2
(psf), angles in rad.  The model is in SI.  The section keeps the model's
coefficients dimensionless and its numbers as they are (SI), and reads
JSBSim's properties through these conversions, each stated once here:

====================  ===========================  =====================
model name (SI)       JSBSim property              factor to SI
====================  ===========================  =====================
V [m/s]               velocities/vt-fps            0.3048
u, v, w [m/s]         velocities/u-aero-fps, ...   0.3048
p, q, r [rad/s]       velocities/p-aero-rad_sec..  1
alpha, beta [rad]     aero/alpha-rad, beta-rad     1
phi, theta, psi       attitude/phi-rad, ...        1
h [m]                 position/h-sl-ft             0.3048
rho [kg/m^3]          atmosphere/rho-slugs_ft3     515.3788184
t [s]                 simulation/sim-time-sec      1
====================  ===========================  =====================

phat = p b/2V, qhat = q cbar/2V, rhat = r b/2V are JSBSim's
p * aero/bi2vel, q * aero/ci2vel, r * aero/bi2vel, written out as
p * metrics/bw-ft / (2 velocities/vt-fps) (dimensionless, so the same in
either unit): aero/bi2vel is set after the section's top-level functions
run (FGAerodynamics::Run), so reading it there would lag one frame.

Forces are qbar S C: aero/qbar-psf * metrics/Sw-sqft * C [lbf]; moments
qbar S b C (roll, yaw) and qbar S cbar C (pitch): metrics/bw-ft,
metrics/cbarw-ft [ft lbf], all in body axes (axes X, Y, Z, ROLL, PITCH,
YAW), about the aerodynamic reference point, which must be the centre of
gravity the model's moments are about.  A model with CD and CL (stability
axes) gives X = qS(-CD cos alpha + CL sin alpha), Z = qS(-CD sin alpha -
CL cos alpha), as mlid_sixdof does.  Each definition of the model is a
top-level function ``aero/mlid/NAME`` (in the model's units), a table a
JSBSim table (linear, held beyond the ends: as mlid's) over the JSBSim
property of its variable, its breakpoints converted to that property's
units.  The model's rho is left to JSBSim's atmosphere (qbar comes from
aero/qbar-psf), and thrust (T, sigT, lT) to its propulsion.
"""

import numpy as np

from ..errors import InputError
from ..files import atomic_write_text
from . import expressions as ex
from .source import Source, Table

FT = 0.3048                      # m per ft (exact)
SLUG = 14.593902937206364        # kg per slug (lbm 0.45359237 kg times g0/ft 32.174049)
LBM = 0.45359237                 # kg per lbm (exact)
SLUG_FT2 = SLUG * FT**2          # kg m^2 per slug ft^2
SLUG_FT3 = SLUG / FT**3          # kg/m^3 per slug/ft^3
PSF = 47.88025898033584          # Pa per lbf/ft^2

#: The model's names JSBSim has as properties: (property, factor to SI).
PROPERTIES = {
    "V": ("velocities/vt-fps", FT), "u": ("velocities/u-aero-fps", FT),
    "v": ("velocities/v-aero-fps", FT), "w": ("velocities/w-aero-fps", FT),
    "p": ("velocities/p-aero-rad_sec", 1.0), "q": ("velocities/q-aero-rad_sec", 1.0),
    "r": ("velocities/r-aero-rad_sec", 1.0), "alpha": ("aero/alpha-rad", 1.0),
    "beta": ("aero/beta-rad", 1.0), "phi": ("attitude/phi-rad", 1.0),
    "theta": ("attitude/theta-rad", 1.0), "psi": ("attitude/psi-rad", 1.0),
    "h": ("position/h-sl-ft", FT), "rho": ("atmosphere/rho-slugs_ft3", SLUG_FT3),
    "t": ("simulation/sim-time-sec", 1.0)}
#: Inputs JSBSim names by default (a control surface in rad, Mach, qbar).
INPUTS = {"de": ("fcs/elevator-pos-rad", 1.0), "da": ("fcs/left-aileron-pos-rad", 1.0),
          "dr": ("fcs/rudder-pos-rad", 1.0), "Mach": ("velocities/mach", 1.0),
          "qbar": ("aero/qbar-psf", PSF)}
#: The rate each normalised rate takes and the length it is made with.
RATES = {"phat": ("p", "metrics/bw-ft"), "qhat": ("q", "metrics/cbarw-ft"),
         "rhat": ("r", "metrics/bw-ft")}
CONSTANTS = ("m", "Ix", "Iy", "Iz", "Ixz", "S", "cbar", "b", "g")
#: The longitudinal kind's constants as mlid_long_text names them.
LONGITUDINAL = ("g", "Sm", "ScIy", "lTIy", "V0", "mass", "sigT", "rho", "c2")
_LEFT_OUT = {"rho": "JSBSim's atmosphere gives qbar (aero/qbar-psf)",
             "T": "thrust belongs to JSBSim's propulsion", "sigT": "thrust inclination",
             "lT": "thrust moment arm"}
#: Each axis: its coefficients, the length of a moment.
AXES = (("X", None), ("Y", None), ("Z", None), ("ROLL", "metrics/bw-ft"),
        ("PITCH", "metrics/cbarw-ft"), ("YAW", "metrics/bw-ft"))


def jsbsim(model_or_result, path, inputs=None, aircraft=False, name="mlid", constants=None):
    """Write an identified aircraft model as JSBSim aerodynamics.

    Parameters
    ----------
    model_or_result : SixDofModel, EquationModel or FitResult
        The model (its parameters' values) or a fit of it (the estimates,
        and each free value's sigma as an XML comment): a
        ``SixDofModel``, or the longitudinal kind written as equations
        (``LongitudinalModel.with_tables``: its S, cbar, m and Iy come
        from its constants S/m, S cbar/Iy, cbar/2 and m).
    path : str or Path
        The file, written whole or not at all.
    inputs : dict, optional
        {input name: property or (property, factor to the model's unit)}
        for inputs other than de, da, dr (fcs/elevator-pos-rad,
        fcs/left-aileron-pos-rad, fcs/rudder-pos-rad), Mach
        (velocities/mach) and qbar (aero/qbar-psf, 47.88 Pa/psf).
    aircraft : bool
        False: the ``<aerodynamics>`` section alone; True: a minimal
        aircraft (``<fdm_config>``): the model's metrics and mass balance,
        the centre of gravity at the origin and the aerodynamic reference
        point on it, one contact point, no propulsion, the same section.
    name : str
        The aircraft's name (with aircraft=True).
    constants : dict, optional
        SI values the model does not hold, for the aircraft: the
        longitudinal kind's Ix, Iz, Ixz [kg m^2] and b [m] (the lateral
        motion stays zero in symmetric flight, but JSBSim needs them).

    Returns
    -------
    str
        The text written.

    Raises
    ------
    InputError
        Neither kind, an input with no property, an expression JSBSim has
        no function for, an aircraft's constant the model lacks, a file
        that cannot be written.
    """
    text = aircraft_text(model_or_result, inputs, name, constants) if aircraft else \
        aerodynamics_text(model_or_result, inputs, constants)
    atomic_write_text(path, text)
    return text


class _Writer:
    """The section's text from a model's parts: the sixdof kind (its text
    names the constants and the air data before the user's definitions), or
    the longitudinal kind written as equations (mlid_long_text: S/m,
    S cbar/Iy, cbar/2, V0, ...; qhat = q cbar/(2 V0) at the fixed V0)."""

    def __init__(self, src, inputs, constants=None):
        self.src = src
        defs = dict(src.definitions)
        order = [n for n, _ in src.definitions]
        self.fixed = {}                                  # a normalised rate's fixed factor
        if all(c in defs for c in CONSTANTS) and "rhat" in defs:
            self.numbers = {c: float(defs[c]) for c in CONSTANTS}
            self.constants = dict(self.numbers)
            first, last = order.index("rhat") + 1, order.index("qbar")
            if order[last - 2:last] == ["CX", "CZ"] and \
                    defs["CX"] == "-CD*cos(alpha) + CL*sin(alpha)":
                last -= 2                                # mlid_sixdof's CX, CZ of CD, CL
        elif all(c in defs for c in LONGITUDINAL) and defs.get("qhat") == "q*c2/V0":
            n = self.numbers = {c: float(defs[c]) for c in LONGITUDINAL}
            self.fixed["qhat"] = ("q", n["c2"] / n["V0"], "cbar/(2 V0), the model's fixed V0")
            S, cbar = n["Sm"] * n["mass"], 2 * n["c2"]
            self.constants = dict(m=n["mass"], S=S, cbar=cbar, Iy=S * cbar / n["ScIy"],
                                  g=n["g"])
            first, last = order.index("qhat") + 1, order.index("qbar")
        else:
            raise InputError("JSBSim export: the model is neither a six-degree-of-freedom "
                             "model (SixDofModel) nor the longitudinal kind written as "
                             "equations (LongitudinalModel.with_tables)")
        self.constants.update({k: float(v) for k, v in (constants or {}).items()})
        self.user = [(n, d) for n, d in src.definitions[first:last]]
        self.props = dict(PROPERTIES)
        for n, prop in {**INPUTS, **(inputs or {})}.items():
            self.props[n] = (prop, 1.0) if isinstance(prop, str) else (prop[0], float(prop[1]))
        self.emitted = set()
        self.lines = []

    # names ---------------------------------------------------------------
    def resolve(self, name, where):
        if name in self.emitted:
            return [f"<property>aero/mlid/{name}</property>"]
        if name in self.src.params:
            return [f"<value>{ex.number(self.src.value(name))}</value>{self._sigma(name)}"]
        if name in self.numbers:
            return [f"<value>{ex.number(self.numbers[name])}</value> <!-- {name} (SI) -->"]
        if name in self.fixed:
            rate, factor, what = self.fixed[name]
            return ex._wrap("product", [self._property(rate),
                                        [f"<value>{ex.number(factor)}</value> <!-- {what} -->"]])
        if name in RATES:
            rate, length = RATES[name]
            return ex._wrap("quotient", [ex._wrap("product", [self._property(rate),
                                                              [f"<property>{length}</property>"]]),
                                         ex._wrap("product", [["<value>2.0</value>"],
                                                              ["<property>velocities/vt-fps"
                                                               "</property>"]])])
        if name in self.props:
            return self._property(name)
        what = "input" if name in self.src.inputs else "name"
        raise InputError(f"JSBSim export: {where}: {what} {name!r} has no JSBSim property "
                         f"(give inputs={{{name!r}: 'property'}})")

    def _property(self, name):
        prop, factor = self.props[name]
        if factor == 1.0:
            return [f"<property>{prop}</property>"]
        return ex._wrap("product", [[f"<value>{ex.number(factor)}</value>"],
                                    [f"<property>{prop}</property>"]])

    def _sigma(self, name):
        s = self.src.sigma.get(name)
        if s is None:
            return f" <!-- {name} -->" if not self.src.fitted else f" <!-- {name}, not free -->"
        return f" <!-- {name}, sigma {s:.4g} -->"

    # parts ---------------------------------------------------------------
    def function(self, name, defn):
        if isinstance(defn, Table):
            body = self.table(defn)
            desc = (f"table {name} over {', '.join(defn.variables)} (mlid: multilinear, held "
                    f"beyond the ends)")
        else:
            tree = ex.parse(defn, f"definition {name}")
            body = ex.elements(tree, lambda n: self.resolve(n, f"definition {name}"),
                               f"definition {name}")
            desc = f"{name} = {defn}"
        self.lines += [f'<function name="aero/mlid/{name}">',
                       f"  <description>{_escape(desc)}</description>",
                       *("  " + line for line in body), "</function>"]
        self.emitted.add(name)

    def table(self, t):
        lookups = ("row", "column", "table")
        out, bps = ["<table>"], []
        for k, v in enumerate(t.variables):
            if v in self.emitted:
                prop, factor = f"aero/mlid/{v}", 1.0
            elif v in RATES or v in self.fixed:     # a property of its own, as resolve writes it
                self.lines += [f'<function name="aero/mlid/{v}">',
                               *("  " + line for line in self.resolve(v, t.name)), "</function>"]
                self.emitted.add(v)
                prop, factor = f"aero/mlid/{v}", 1.0
            elif v in self.props:
                prop, factor = self.props[v]
            else:
                raise InputError(f"JSBSim export: table {t.name}: variable {v!r} has no JSBSim "
                                 f"property")
            bps.append(t.breakpoints[k] / factor)
            unit = "" if factor == 1.0 else f" (breakpoints: the model's / {ex.number(factor)})"
            out.append(f'  <independentVar lookup="{lookups[k]}">{prop}</independentVar>'
                       + (f" <!-- {v}{unit} -->"))
        out += ["  " + line for line in _table_data(bps, t.values)]
        out.append("</table>")
        if np.any(np.isfinite(t.sigma)):
            out += [f"<!-- sigma of {t.name}'s values (the fit's Cramer-Rao bound; "
                    f"'-': not free), laid out as the values:"]
            out += ["     " + line for line in _table_data(bps, t.sigma, sigma=True)]
            out.append("-->")
        return out

    def axis(self, axis, length):
        coeff = {"X": "CX", "Y": "CY", "Z": "CZ", "ROLL": "Cl", "PITCH": "Cm", "YAW": "Cn"}[axis]
        stab = "CD" in self.emitted and axis in ("X", "Z")
        if not stab and coeff not in self.emitted:
            return
        head = ["<property>aero/qbar-psf</property>", "<property>metrics/Sw-sqft</property>"]
        if length:
            head.append(f"<property>{length}</property>")
        if stab:
            a = "<property>aero/alpha-rad</property>"
            cd = ["<property>aero/mlid/CD</property>"]
            cl = ["<property>aero/mlid/CL</property>"]
            if axis == "X":         # CX = -CD cos(alpha) + CL sin(alpha)
                c = ex._wrap("sum", [ex._wrap("product", [["<value>-1.0</value>"], cd,
                                                          [f"<cos>{a}</cos>"]]),
                                     ex._wrap("product", [cl, [f"<sin>{a}</sin>"]])])
                desc = "qbar S CX, CX = -CD cos(alpha) + CL sin(alpha)"
            else:                   # CZ = -CD sin(alpha) - CL cos(alpha)
                c = ex._wrap("product", [["<value>-1.0</value>"], ex._wrap("sum", [
                    ex._wrap("product", [cd, [f"<sin>{a}</sin>"]]),
                    ex._wrap("product", [cl, [f"<cos>{a}</cos>"]])])])
                desc = "qbar S CZ, CZ = -CD sin(alpha) - CL cos(alpha)"
        else:
            c = [f"<property>aero/mlid/{coeff}</property>"]
            desc = f"qbar S {'b ' if length == 'metrics/bw-ft' else 'cbar ' if length else ''}" \
                   f"{coeff}"
        self.lines += [f'<axis name="{axis}">', f'  <function name="aero/mlid/{axis.lower()}">',
                       f"    <description>{desc}</description>",
                       *("    " + line for line in ex._wrap("product", [head, c])),
                       "  </function>", "</axis>"]

    def section(self):
        c = self.constants
        self.lines += [
            "<!-- mlid's identified model (SI) in JSBSim's units: the model's",
            "     numbers as they are, JSBSim's properties converted to SI where read",
            "     (ft -> m: * 0.3048; slug/ft^3 -> kg/m^3: * 515.3788184; psf -> Pa: *",
            "     47.88025898), rates normalised as aero/bi2vel, aero/ci2vel.  Forces qbar S C",
            "     [lbf], moments qbar S b C, qbar S cbar C [ft lbf], body axes, about the",
            "     aerodynamic reference point (the model's centre of gravity).  The aircraft's",
            "     metrics must be the model's: " + ", ".join(
                f"{k} = {c[k]!r} m{'^2' if k == 'S' else ''} = "
                f"{c[k] / FT**(2 if k == 'S' else 1)!r} ft{'^2' if k == 'S' else ''}"
                for k in ("S", "b", "cbar") if k in c) + ". -->"]
        for name, defn in self.user:
            if name in _LEFT_OUT:
                self.lines.append(f"<!-- {name} left out: {_LEFT_OUT[name]} -->")
                continue
            self.function(name, defn)
        for axis, length in AXES:
            self.axis(axis, length)
        return ["<aerodynamics>", *("  " + line for line in self.lines), "</aerodynamics>"]


def aerodynamics_text(model_or_result, inputs=None, constants=None):
    """The ``<aerodynamics>`` section's text (see ``jsbsim``)."""
    return "\n".join(['<?xml version="1.0"?>', *_Writer(Source(model_or_result), inputs,
                                                         constants).section()]) + "\n"


def aircraft_text(model_or_result, inputs=None, name="mlid", constants=None):
    """A minimal JSBSim aircraft around the section (see ``jsbsim``)."""
    w = _Writer(Source(model_or_result), inputs, constants)
    c = w.constants
    missing = [k for k in CONSTANTS if k not in c]
    if missing:
        raise InputError(f"JSBSim aircraft: the model has no {', '.join(missing)}: give "
                         f"constants={{{', '.join(repr(k) + ': ...' for k in missing)}}} (SI)")
    aero = w.section()
    def location(n):
        return [f'<location name="{n}" unit="IN"> <x> 0 </x> <y> 0 </y> <z> 0 </z> </location>']

    metrics = ["<metrics>",
               f'  <wingarea unit="FT2"> {c["S"] / FT**2!r} </wingarea> <!-- S / 0.3048^2 -->',
               f'  <wingspan unit="FT"> {c["b"] / FT!r} </wingspan> <!-- b / 0.3048 -->',
               f'  <chord unit="FT"> {c["cbar"] / FT!r} </chord> <!-- cbar / 0.3048 -->',
               *("  " + s for s in location("AERORP") + location("EYEPOINT")
                 + location("VRP")), "</metrics>"]
    # negated_crossproduct_inertia="false": ixz is the integral of x z dm
    # (mlid's Ixz, body axes); JSBSim puts -ixz into the tensor.
    inertia = [f'  <{tag} unit="SLUG*FT2"> {c[k] / SLUG_FT2!r} </{tag}> '
               f'<!-- {k} [kg m^2] / {SLUG_FT2!r} -->'
               for k, tag in (("Ix", "ixx"), ("Iy", "iyy"), ("Iz", "izz"))]
    mass = ['<mass_balance negated_crossproduct_inertia="false">', *inertia,
            f'  <ixz unit="SLUG*FT2"> {c["Ixz"] / SLUG_FT2!r} </ixz> '
            f'<!-- Ixz [kg m^2] / {SLUG_FT2!r} -->',
            f'  <emptywt unit="LBS"> {c["m"] / LBM!r} </emptywt> <!-- m [kg] / 0.45359237 -->',
            *("  " + s for s in location("CG")), "</mass_balance>"]
    ground = ['<ground_reactions>', '  <contact type="STRUCTURE" name="CONTACT">',
              '    <location unit="FT"> <x> 0 </x> <y> 0 </y> <z> -1 </z> </location>',
              "    <static_friction> 0.8 </static_friction>",
              "    <dynamic_friction> 0.5 </dynamic_friction>",
              f'    <spring_coeff unit="LBS/FT"> {100 * c["m"] / LBM!r} </spring_coeff>',
              f'    <damping_coeff unit="LBS/FT/SEC"> {10 * c["m"] / LBM!r} </damping_coeff>',
              "  </contact>", "</ground_reactions>"]
    lines = ['<?xml version="1.0"?>',
             f'<fdm_config name="{_escape(name)}" version="2.0" release="ALPHA">',
             "  <fileheader>",
             "    <author> mlid </author>",
             "    <description> an identified model: metrics, mass balance and "
             "aerodynamics (mlid.export.jsbsim) </description>",
             "  </fileheader>",
             *("  " + s for s in metrics + mass + ground + aero), "</fdm_config>"]
    return "\n".join(lines) + "\n"


def _table_data(bps, values, sigma=False):
    """<tableData> lines (1, 2 or 3 variables), or the same layout of sigma
    ('-' where none) without the tags."""
    b = ex.number

    def f(v):
        if not sigma:
            return ex.number(v)
        return "-" if not np.isfinite(v) else f"{v:.4g}"

    def block(vals, b1, b2, head):
        rows = [head] if head else []
        if b2 is None:
            rows += [f"  {b(x)} {f(y)}" for x, y in zip(b1, vals)]
        else:
            rows.append("  " + " ".join(b(x) for x in b2))
            rows += [f"  {b(x)} " + " ".join(f(y) for y in row) for x, row in zip(b1, vals)]
        return rows + ([] if sigma else ["</tableData>"])

    if len(bps) < 3:
        return block(values, bps[0], bps[1] if len(bps) == 2 else None,
                     "" if sigma else "<tableData>")
    out = []
    for k, b3 in enumerate(bps[2]):
        head = f"at {b(b3)}:" if sigma else f'<tableData breakPoint="{b(b3)}">'
        out += block(values[:, :, k], bps[0], bps[1], head)
    return out


def _escape(s):
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
