"""Arrays of a result whose entries are also reached by parameter name:
``res.estimate['M_q']``, ``res.covariance['M_q', 'Z_w']``, while they stay
numpy arrays (arithmetic, numpy functions, indexing by position)."""

import numpy as np


def _plain(x):
    """x with every NamedArray in it (lists, tuples, dicts too) a plain
    ndarray view of the same memory."""
    if isinstance(x, NamedArray):
        return x.view(np.ndarray)
    if isinstance(x, list):
        return [_plain(v) for v in x]
    if isinstance(x, tuple):
        return tuple(_plain(v) for v in x)
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    return x


class NamedArray(np.ndarray):
    """An ndarray whose entries along its named axes have names.

    A name stands for its position wherever an index goes: ``a['M_q']``,
    ``a[['M_q', 'Z_w']]``, ``c['M_q', 'Z_w']`` for a matrix named on both
    axes; ``a['M_q'] = 1.0`` sets it.  Element by element arithmetic with
    scalars, plain arrays or arrays of the same names keeps the names
    (``(res.estimate - truth)['M_q']``); anything else computed from it
    (reductions, slices, numpy functions) is a plain ndarray, since its
    entries need no longer be the named ones.  ``to_series`` gives a pandas
    Series of a vector.

    Parameters
    ----------
    values : array_like
        The values (the array is a view of them where numpy can make one).
    names : sequence of str
        One name per entry along each named axis.
    axes : tuple of int, optional
        The named axes (default: every axis, a vector's or a square
        matrix's); each must have one entry per name.

    Raises
    ------
    ValueError
        If a named axis does not have one entry per name.
    """

    def __new__(cls, values, names, axes=None):
        a = np.asarray(values).view(cls)
        names = tuple(str(n) for n in names)
        axes = tuple(range(a.ndim)) if axes is None else tuple(axes)
        for ax in axes:
            if a.shape[ax] != len(names):
                raise ValueError(f"NamedArray: axis {ax} has {a.shape[ax]} entries for "
                                 f"{len(names)} names")
        a._names, a._axes = names, axes
        return a

    def __array_finalize__(self, obj):
        # a derived array (a view, a reshape, a transpose, a copy numpy
        # makes) has no names: its entries need not be the named ones
        self._names, self._axes = None, ()

    @property
    def names(self):
        """The names, in order (None for an array derived from a named one)."""
        return None if self._names is None else list(self._names)

    def _position(self, axis, name):
        if axis not in self._axes:
            raise IndexError(f"axis {axis} of this array has no names: index it by position")
        try:
            return self._names.index(name)
        except ValueError:
            raise KeyError(f"no entry named {name!r}; the names are "
                           f"{', '.join(self._names)}") from None

    def _positions(self, key):
        """key with each name in it replaced by its position."""
        if self._names is None:
            if _has_name(key):
                raise IndexError("this array has no names (it was derived from a named one): "
                                 "index it by position")
            return key
        if isinstance(key, str):
            return self._position(0, key)
        if isinstance(key, list) and key and all(isinstance(k, str) for k in key):
            return [self._position(0, k) for k in key]
        if isinstance(key, tuple):
            return tuple(self._positions_on(axis, k) for axis, k in enumerate(key))
        return key

    def _positions_on(self, axis, k):
        if isinstance(k, str):
            return self._position(axis, k)
        if isinstance(k, list) and k and all(isinstance(v, str) for v in k):
            return [self._position(axis, v) for v in k]
        return k

    def __getitem__(self, key):
        return self.view(np.ndarray)[self._positions(key)]

    def __contains__(self, key):
        """A name is in it when it names an entry; a number, when it equals one."""
        if isinstance(key, str):
            return self._names is not None and key in self._names
        return super().__contains__(key)

    def __setitem__(self, key, value):
        self.view(np.ndarray)[self._positions(key)] = _plain(value)

    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        out = kwargs.get("out")
        if out is not None:
            kwargs["out"] = tuple(_plain(o) for o in out)
        result = getattr(ufunc, method)(*_plain(inputs), **kwargs)
        if out is not None:
            return out[0] if len(out) == 1 else out
        if method == "__call__" and ufunc.nout == 1:
            return self._named_like(result, inputs)
        return result

    def _named_like(self, result, inputs):
        """result, element by element of inputs, with their names when every
        named input has the same names, axes and result's shape."""
        named = [x for x in inputs if isinstance(x, NamedArray) and x._names is not None]
        if not named or not isinstance(result, np.ndarray):
            return result
        first = named[0]
        if all(x._names == first._names and x._axes == first._axes and x.shape == result.shape
               for x in named):
            return NamedArray(result, first._names, first._axes)
        return result

    def __array_function__(self, func, types, args, kwargs):
        return func(*_plain(args), **_plain(kwargs))

    def copy(self, order="C"):
        """A copy, with the names."""
        out = np.ndarray.copy(self, order=order)
        out._names, out._axes = self._names, self._axes
        return out

    def __copy__(self):
        return self.copy()

    def __deepcopy__(self, memo):
        return self.copy()

    def __reduce__(self):
        rebuild, args, state = np.ndarray.__reduce__(self)
        return rebuild, args, (state, self._names, self._axes)

    def __setstate__(self, state):
        base, self._names, self._axes = state
        np.ndarray.__setstate__(self, base)

    def sort(self, *args, **kwargs):
        """Sort in place; the entries are then no longer the named ones, so
        the names go."""
        np.ndarray.sort(self.view(np.ndarray), *args, **kwargs)
        self._names, self._axes = None, ()

    def to_series(self):
        """A named vector as a pandas Series indexed by name.

        Returns
        -------
        pandas.Series

        Raises
        ------
        InputError
            If pandas is not installed.
        ValueError
            If the array is not a named vector.
        """
        from ..checks import pandas_for
        if self._names is None or self.ndim != 1:
            raise ValueError("to_series needs a named vector")
        pd = pandas_for("NamedArray.to_series")
        return pd.Series(self.view(np.ndarray).copy(), index=pd.Index(self._names, name="name"))

    def __repr__(self):
        plain = self.view(np.ndarray)
        if self._names is None:
            return repr(plain)
        text = np.array2string(plain, separator=", ", prefix="NamedArray(")
        return f"NamedArray({text}, names={list(self._names)})"


def _has_name(key):
    if isinstance(key, str):
        return True
    if isinstance(key, (list, tuple)):
        return any(isinstance(k, str) or (isinstance(k, list) and any(isinstance(v, str)
                                                                      for v in k))
                   for k in key)
    return False
