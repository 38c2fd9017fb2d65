"""Parameters of a fit, as lmfit has them: value, bounds, free or fixed, an expression, stderr, correlations.

A :class:`Parameter` is one unknown (or known) number of a fit: a model
parameter of :mod:`iwp.models` (``p1``, ``k_over_I2``, ...), an initial state
or a sensor offset of one experiment. It carries its value, its bounds,
whether the fit varies it, an expression when it is derived from others
(``p2 * (1 + rho)``), how the optimiser sees it (a scale, or a log scale),
and, after a fit, its standard error, its 95 % interval and its correlations.

:class:`Parameters` is the ordered set of them that a
:class:`~iwp.ident.problem.FitProblem` varies. It maps the values to the
optimiser's coordinates ``z`` (``value / scale``, or ``log value``) and
back, evaluates the expressions, and gives derived parameters their
uncertainty by the delta method.

>>> from iwp.ident.fit_parameters import Parameter, Parameters
>>> ps = Parameters([Parameter("p2", 0.0106), Parameter("rho", 247.24, vary=False),
...                  Parameter("p2_1rho", 0.0, expr="p2 * (1 + rho)")])
>>> round(ps.values()["p2_1rho"], 4)
2.6313
"""

from __future__ import annotations

import ast
import math
import operator
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Iterable, Iterator, Mapping, Sequence

import numpy as np

from ..errors import InputError
from ..files import json_float

__all__ = ["Parameter", "Parameters", "evaluate_expression", "parameter_table", "closing_lines"]


@dataclass(frozen=True)
class Parameter:
    """One parameter of a fit.

    Parameters
    ----------
    name : str
        Its name: a model parameter (:data:`iwp.models.parameters.PARAMETER_INFO`),
        a derived one (``p2_1rho``), an initial state (``"q1(0) of experiment 0"``)
        or an offset (``"offset of q1 in experiment 0"``).
    value : float
        Its value (start value before a fit, estimate after), in ``unit``.
    vary : bool
        The fit varies it (free); False: fixed at ``value``, or derived by ``expr``.
    min, max : float
        Bounds of a free parameter (``-inf``/``inf``: none).
    expr : str, optional
        An expression over other parameters' names (``+ - * / **``, numbers,
        ``sqrt``, ``exp``, ``log``) that defines its value; it is then not varied.
    stderr : float
        Standard error after a fit (0 for a fixed parameter, NaN where the data
        do not determine it).
    ci95 : (float, float), optional
        The 95 % interval after a fit (default ``(value, value)``).
    correl : dict of str to float
        Correlation with the other free parameters after a fit.
    unit : str
    log : bool
        The optimiser varies ``log value`` (a positive parameter spanning decades).
    scale : float, optional
        The optimiser varies ``value / scale`` (default: ``|value|``, or 1 for 0).
    kind : {"model", "initial state", "offset"}
        What it is: reports list the model's parameters apart from the nuisance ones.
    note : str
        A remark the tables print beside it (``"held at its prior: not identified by these logs"``).
    """

    name: str
    value: float
    vary: bool = True
    min: float = -math.inf
    max: float = math.inf
    expr: str | None = None
    stderr: float = 0.0
    ci95: tuple[float, float] | None = None
    correl: Mapping[str, float] = field(default_factory=dict)
    unit: str = ""
    log: bool = False
    scale: float | None = None
    kind: str = "model"
    note: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InputError(f"a parameter's name must be a non-empty string, got {self.name!r}")
        v = self.value
        if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
            raise InputError(f"parameter {self.name!r}: value must be a number, got {v!r}")
        object.__setattr__(self, "value", float(v))
        if self.expr is not None:
            object.__setattr__(self, "vary", False)
        if self.vary:
            lo, hi = float(self.min), float(self.max)
            if math.isnan(lo) or math.isnan(hi) or not lo < hi:
                raise InputError(f"parameter {self.name!r}: bounds ({lo}, {hi}): low must be < high")
            if self.log and not lo >= 0.0:
                raise InputError(f"parameter {self.name!r}: a log-scale parameter needs bounds > 0, got low {lo}")
            if self.log and not self.value > 0.0:
                raise InputError(f"start value of {self.name} must be > 0 to be fitted on a log scale, "
                                 f"got {self.value:g}")

    # ------------------------------------------------------------------ views
    @property
    def fixed(self) -> bool:
        """True if the value was given, not estimated (neither free nor derived)."""
        return not self.vary and self.expr is None

    @property
    def ci95_low(self) -> float:
        """Lower end of the 95 % interval."""
        return self.value if self.ci95 is None else self.ci95[0]

    @property
    def ci95_high(self) -> float:
        """Upper end of the 95 % interval."""
        return self.value if self.ci95 is None else self.ci95[1]

    def optimiser_scale(self) -> float:
        """The scale ``s`` of the optimiser's coordinate ``z = value / s`` (linear parameters)."""
        if self.scale is not None:
            return float(self.scale)
        return abs(self.value) if self.value != 0.0 else 1.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-able ``{"value", "stderr", "ci95": [lo, hi], "fixed"}`` (NaN -> None; ``"expr"`` when derived)."""
        out = {"value": json_float(self.value), "stderr": json_float(self.stderr),
               "ci95": [json_float(self.ci95_low), json_float(self.ci95_high)], "fixed": self.fixed}
        if self.expr is not None:
            out["expr"] = self.expr
        if self.note:
            out["note"] = self.note
        return out

    @classmethod
    def estimate(cls, name: str, value: float, stderr: float, critical: float, **kw: Any) -> "Parameter":
        """An estimated parameter with its interval ``value +- critical * stderr``."""
        value, stderr = float(value), float(stderr)
        return cls(name, value, stderr=stderr, ci95=(value - critical * stderr, value + critical * stderr), **kw)

    @classmethod
    def given(cls, name: str, value: float, **kw: Any) -> "Parameter":
        """A fixed parameter (not estimated): stderr 0, interval ``[value, value]``."""
        return cls(name, float(value), vary=False, **kw)


# --------------------------------------------------------------------------
# expressions
# --------------------------------------------------------------------------
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.Pow: operator.pow}
_UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos}
_FUNCTIONS = {"sqrt": math.sqrt, "exp": math.exp, "log": math.log, "abs": abs}


def _names_in(expr: str) -> set[str]:
    return {n.id for n in ast.walk(_parse(expr)) if isinstance(n, ast.Name) and n.id not in _FUNCTIONS}


def _parse(expr: str) -> ast.Expression:
    try:
        return ast.parse(expr, mode="eval")
    except SyntaxError:
        raise InputError(f"expression {expr!r} is not valid") from None


def evaluate_expression(expr: str, values: Mapping[str, float]) -> float:
    """The value of ``expr`` (names, numbers, ``+ - * / **``, ``sqrt exp log abs``) for the named ``values``.

    Parameters
    ----------
    expr : str
        The expression, in Python syntax.
    values : mapping of str to float
        Value of each name.

    Returns
    -------
    float
        The value; NaN outside an operation's domain (a division by zero, ``log`` of a negative number).

    Raises
    ------
    InputError
        Invalid syntax, a name not in ``values``, or an operation or function not allowed.
    """

    def ev(node: ast.AST) -> float:
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value,
                                                                                                        bool):
            return float(node.value)
        if isinstance(node, ast.Name):
            if node.id not in values:
                raise InputError(f"expression {expr!r} names {node.id!r}, which is not a parameter")
            return float(values[node.id])
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return _BINARY[type(node.op)](ev(node.left), ev(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            return _UNARY[type(node.op)](ev(node.operand))
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _FUNCTIONS
                and len(node.args) == 1 and not node.keywords):
            return float(_FUNCTIONS[node.func.id](ev(node.args[0])))
        raise InputError(f"expression {expr!r}: only numbers, parameter names, + - * / ** and sqrt, exp, log, abs "
                         "are allowed")

    try:
        return ev(_parse(expr))
    except InputError:
        raise
    except (ZeroDivisionError, ValueError, OverflowError):  # outside the domain of an operation
        return math.nan


# --------------------------------------------------------------------------
# the set
# --------------------------------------------------------------------------
class Parameters(Mapping[str, Parameter]):
    """An ordered, immutable set of :class:`Parameter`, by name.

    Parameters
    ----------
    params : iterable of Parameter
        Names must be unique; expressions may name any other parameter of the
        set (no circular definitions).
    """

    def __init__(self, params: Iterable[Parameter] = ()):
        items: dict[str, Parameter] = {}
        for p in params:
            if not isinstance(p, Parameter):
                raise InputError(f"Parameters holds Parameter objects, got {type(p).__name__}")
            if p.name in items:
                raise InputError(f"parameter {p.name!r} is given twice")
            items[p.name] = p
        self._items = items
        self._order = self._expression_order()

    # Mapping ---------------------------------------------------------------
    def __getitem__(self, name: str) -> Parameter:
        try:
            return self._items[name]
        except KeyError:
            raise KeyError(f"no parameter {name!r}; known: {', '.join(self._items)}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __repr__(self) -> str:
        inner = ", ".join(f"{p.name}={p.value:.6g}{'' if p.vary else ' (fixed)' if p.expr is None else ' (expr)'}"
                          for p in self._items.values())
        return f"Parameters({inner})"

    def _expression_order(self) -> list[str]:
        """Derived parameters in an order in which each one's names are known before it."""
        derived = {n: _names_in(p.expr) for n, p in self._items.items() if p.expr is not None}
        for n, names in derived.items():
            unknown = sorted(names - set(self._items))
            if unknown:
                raise InputError(f"parameter {n!r}: its expression names {unknown[0]!r}, which is not a parameter")
        order: list[str] = []
        pending = dict(derived)
        while pending:
            ready = [n for n, names in pending.items() if not (names & set(pending))]
            if not ready:
                raise InputError(f"the expressions of {', '.join(sorted(pending))} define each other in a circle")
            for n in ready:
                order.append(n)
                del pending[n]
        return order

    # ------------------------------------------------------------------ views
    @property
    def free(self) -> tuple[str, ...]:
        """Names of the parameters the fit varies, in order."""
        return tuple(n for n, p in self._items.items() if p.vary)

    def of_kind(self, kind: str) -> tuple[str, ...]:
        """Names of the parameters of one kind (``"model"``, ``"initial state"``, ``"offset"``)."""
        return tuple(n for n, p in self._items.items() if p.kind == kind)

    def values(self) -> dict[str, float]:  # type: ignore[override]
        """``{name: value}`` of every parameter, the derived ones evaluated from the others."""
        vals = {n: p.value for n, p in self._items.items()}
        for n in self._order:
            vals[n] = evaluate_expression(self._items[n].expr, vals)
        return vals

    def replace(self, name: str, **changes: Any) -> "Parameters":
        """A copy with one parameter's fields changed."""
        return Parameters(replace(p, **changes) if n == name else p for n, p in self._items.items())

    def with_values(self, values: Mapping[str, float]) -> "Parameters":
        """A copy with the values of the named parameters set."""
        unknown = [n for n in values if n not in self._items]
        if unknown:
            raise InputError(f"no parameter {unknown[0]!r}; known: {', '.join(self._items)}")
        return Parameters(replace(p, value=float(values[n])) if n in values else p for n, p in self._items.items())

    # ---------------------------------------------------------------- optimiser
    def to_internal(self) -> np.ndarray:
        """The optimiser's coordinates ``z`` of the free parameters (``value/scale`` or ``log value``)."""
        for n in self.free:
            if not math.isfinite(self._items[n].value):
                raise InputError(f"parameter {n!r}: start value must be finite, got {self._items[n].value!r}")
        return np.array([math.log(p.value) if p.log else p.value / p.optimiser_scale()
                         for p in (self._items[n] for n in self.free)], dtype=float)

    def internal_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of ``z``."""
        lo, hi = [], []
        for p in (self._items[n] for n in self.free):
            if p.log:
                lo.append(math.log(p.min) if p.min > 0 else -math.inf)
                hi.append(math.log(p.max) if math.isfinite(p.max) else math.inf)
            else:
                s = p.optimiser_scale()
                lo.append(p.min / s)
                hi.append(p.max / s)
        return np.array(lo), np.array(hi)

    def from_internal(self, z: np.ndarray) -> dict[str, float]:
        """``{name: value}`` of every parameter for the optimiser's coordinates ``z`` (expressions evaluated)."""
        vals = {n: p.value for n, p in self._items.items()}
        for zi, n in zip(z, self.free):
            p = self._items[n]
            vals[n] = math.exp(zi) if p.log else zi * p.optimiser_scale()
        for n in self._order:
            vals[n] = evaluate_expression(self._items[n].expr, vals)
        return vals

    def value_derivatives(self, z: np.ndarray, names: Sequence[str]) -> np.ndarray:
        """``d value / d z``, shape ``(len(names), n_free)``: free parameters exactly, derived ones numerically."""
        free = self.free
        vals = self.from_internal(z)
        D = np.zeros((len(names), len(free)))
        for j, n in enumerate(free):
            p = self._items[n]
            dvdz = vals[n] if p.log else p.optimiser_scale()
            for i, m in enumerate(names):
                if m == n:
                    D[i, j] = dvdz
        derived = [i for i, m in enumerate(names) if self._items[m].expr is not None] if names else []
        if derived:
            for j in range(len(free)):
                h = 1e-7 * max(1.0, abs(z[j]))
                zp = np.array(z, dtype=float)
                zp[j] += h
                vp = self.from_internal(zp)
                for i in derived:
                    D[i, j] = (vp[names[i]] - vals[names[i]]) / h
        return D

    def depends_on_free(self, name: str) -> bool:
        """True if ``name`` varies with the fit (free, or derived from a free parameter)."""
        p = self._items[name]
        if p.vary:
            return True
        if p.expr is None:
            return False
        return any(self.depends_on_free(m) for m in _names_in(p.expr))

    # ------------------------------------------------------------------ report
    def with_estimates(self, z: np.ndarray, covariance_z: np.ndarray,
                       critical: float | Callable[[np.ndarray], float]) -> "Parameters":
        """The parameters at the optimum ``z`` with standard errors, 95 % intervals and correlations.

        ``covariance_z`` is the covariance of ``z``; it is mapped to the values
        by the delta method (``D C D^T`` with ``D = d value / d z``), for the free
        and for the derived parameters alike. ``critical``: the multiplier of
        the standard errors, or a function of a parameter's row of ``D`` that
        gives its own (:meth:`iwp.ident.covariance.Covariance.critical_of`).
        """
        vals = self.from_internal(z)
        names = [n for n in self._items if self.depends_on_free(n)]
        D = self.value_derivatives(z, names)
        with np.errstate(invalid="ignore"):
            cov = D @ covariance_z @ D.T if len(names) else np.zeros((0, 0))
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None)) if len(names) else np.zeros(0)
        sd = np.where(np.isnan(np.diag(cov)), np.nan, sd) if len(names) else sd
        free = set(self.free)
        out = []
        for n, p in self._items.items():
            v = vals[n]
            if n in names:
                i = names.index(n)
                s = float(sd[i])
                correl = {}
                for k, m in enumerate(names):
                    if m != n and m in free and p.vary:
                        with np.errstate(invalid="ignore", divide="ignore"):
                            correl[m] = float(cov[i, k] / (sd[i] * sd[k]))
                c = critical(D[i]) if callable(critical) else critical
                out.append(replace(p, value=float(v), stderr=s, ci95=(v - c * s, v + c * s), correl=correl))
            else:
                out.append(replace(p, value=float(v), stderr=0.0, ci95=None, correl={}))
        return Parameters(out)

    def to_dict(self, kinds: Sequence[str] = ("model",)) -> dict[str, dict[str, Any]]:
        """JSON-able ``{name: Parameter.to_dict()}`` of the parameters of ``kinds``."""
        return {n: p.to_dict() for n, p in self._items.items() if p.kind in kinds}


# --------------------------------------------------------------------------
# reports
# --------------------------------------------------------------------------
def parameter_table(params: Iterable[Parameter], units: Mapping[str, str] | None = None) -> list[str]:
    """The lines of a table of estimates: name, value, stderr, 95 % interval, unit and a note.

    The note says ``fixed`` (given, not estimated) or ``not identifiable``
    (no finite standard error). ``units`` overrides the parameters' own.

    Parameters
    ----------
    params : iterable of Parameter
        The estimates.
    units : mapping of str to str, optional
        Unit of each name, replacing the parameter's own.

    Returns
    -------
    list of str
        The header line, then one line per parameter.
    """
    params = list(params)
    w = max([9] + [len(p.name) for p in params])
    lines = [f"{'parameter':<{w}}  {'value':>13}  {'stderr':>11}  {'95% interval':^29}  unit"]
    for p in params:
        note = p.note or ("fixed" if p.fixed else ("not identifiable" if not math.isfinite(p.stderr) else ""))
        unit = (units or {}).get(p.name, p.unit)
        lines.append(f"{p.name:<{w}}  {p.value:>13.6g}  {p.stderr:>11.3g}  "
                     f"[{p.ci95_low:>12.6g}, {p.ci95_high:>12.6g}]  {unit} {note}".rstrip())
    return lines


def closing_lines(warnings: Sequence[str], message: str) -> list[str]:
    """The last lines of a summary: the warnings, then the verdict.

    Parameters
    ----------
    warnings : sequence of str
        Warnings (none: no ``warnings:`` line).
    message : str
        The verdict, last.

    Returns
    -------
    list of str
        The lines.
    """
    lines = []
    if warnings:
        lines.append("warnings:")
        lines.extend(f"  - {m}" for m in warnings)
    lines.append(message)
    return lines
