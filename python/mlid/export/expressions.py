"""An expression of the models' language (+ - * / ^, the functions of
derived channels, pi) as the elements of a JSBSim function: <sum>,
<difference>, <product>, <quotient>, <pow>, <sin>, ..., <value>,
<property>.  Names are resolved by the caller: each becomes a property
(times a unit factor) or a value."""

import ast

from ..errors import InputError

#: The models' functions and JSBSim's element of each (FGFunction.cpp);
#: tanh has none and is written with exp.
FUNCTIONS = {"sin": "sin", "cos": "cos", "tan": "tan", "asin": "asin", "acos": "acos",
             "atan": "atan", "atan2": "atan2", "sqrt": "sqrt", "abs": "abs", "exp": "exp",
             "log": "ln", "log10": "log10", "min": "min", "max": "max"}
_OPS = {ast.Add: "sum", ast.Sub: "difference", ast.Mult: "product", ast.Div: "quotient",
        ast.Pow: "pow"}


def number(v):
    """A number as JSBSim reads it, exactly (17 significant digits)."""
    return repr(float(v))


def parse(text, where):
    """The expression's tree (Python's, with ^ read as a power)."""
    try:
        return ast.parse(text.replace("^", "**"), mode="eval").body
    except SyntaxError:
        raise InputError(f"{where}: cannot read the expression {text!r}") from None


def names(tree):
    """The names an expression reads (functions and pi left out)."""
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)
            and n.id not in FUNCTIONS and n.id not in ("tanh", "pi")}


def elements(tree, resolve, where):
    """The JSBSim elements of a tree, one list of lines (no indentation);
    resolve(name) gives a name's lines."""
    if isinstance(tree, ast.Constant) and isinstance(tree.value, (int, float)):
        return [f"<value>{number(tree.value)}</value>"]
    if isinstance(tree, ast.Name):
        if tree.id == "pi":
            return ["<pi/>"]
        return resolve(tree.id)
    if isinstance(tree, ast.UnaryOp) and isinstance(tree.op, (ast.USub, ast.UAdd)):
        operand = tree.operand
        if isinstance(operand, ast.Constant) and isinstance(operand.value, (int, float)):
            sign = -1.0 if isinstance(tree.op, ast.USub) else 1.0
            return [f"<value>{number(sign * operand.value)}</value>"]
        inner = elements(operand, resolve, where)
        return inner if isinstance(tree.op, ast.UAdd) else \
            _wrap("product", [["<value>-1.0</value>"], inner])
    if isinstance(tree, ast.BinOp) and type(tree.op) in _OPS:
        tag = _OPS[type(tree.op)]
        parts = ([*_flat(tree.left, type(tree.op)), *_flat(tree.right, type(tree.op))]
                 if tag in ("sum", "product") else [tree.left, tree.right])
        return _wrap(tag, [elements(p, resolve, where) for p in parts])
    if isinstance(tree, ast.Call) and isinstance(tree.func, ast.Name) and not tree.keywords:
        args = [elements(a, resolve, where) for a in tree.args]
        fn = tree.func.id
        if fn == "tanh" and len(args) == 1:     # tanh x = (e^2x - 1)/(e^2x + 1)
            e2x = _wrap("exp", [_wrap("product", [["<value>2.0</value>"], args[0]])])
            one = ["<value>1.0</value>"]
            return _wrap("quotient", [_wrap("difference", [e2x, one]), _wrap("sum", [e2x, one])])
        if fn in FUNCTIONS:
            return _wrap(FUNCTIONS[fn], args)
    raise InputError(f"{where}: JSBSim has no function for {ast.unparse(tree)!r}")


def _flat(tree, op):
    """The operands of a chain of one associative operator."""
    if isinstance(tree, ast.BinOp) and isinstance(tree.op, op):
        return [*_flat(tree.left, op), *_flat(tree.right, op)]
    return [tree]


def _wrap(tag, parts):
    return [f"<{tag}>", *("  " + line for part in parts for line in part), f"</{tag}>"]
