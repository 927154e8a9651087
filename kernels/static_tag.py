"""A number that names what a kernel factory unrolls, for Warp's kernel cache.

Warp (1.19) hashes a `wp.static(...)` expression's value when the expression is resolved at
declaration, but not one that reads an unrolled loop's variable (`wp.static(TABLE[i])`): two
variants that differ only in such a table (the material kinds of the kind table a scene has, a
strategy's lobe samplers) get the same module hash, and the second process to build one loads the
other's binary from the disk cache (reproduced: a loop over (9,) and over (10,) in two processes
sharing a cache). A function that unrolls a table therefore reads `wp.static(variant_tag(TABLE))`
once outside the loop: a declaration-time static, hashed by value, that changes with the table's
numbers and with the source of every Warp function or module in it."""
import hashlib
import inspect


def _part(x) -> str:
    if isinstance(x, (tuple, list)):
        return "(" + ",".join(_part(y) for y in x) + ")"
    fn = getattr(x, "func", None)                  # a Warp function: its Python source
    target = fn if fn is not None else x
    if inspect.isfunction(target) or inspect.ismodule(target):
        try:
            return hashlib.sha256(inspect.getsource(target).encode()).hexdigest()[:16]
        except (OSError, TypeError):
            return f"id{id(target)}"               # no source to read: never shared across objects
    return repr(x)


def variant_tag(table) -> int:
    """A 31-bit number of `table`'s contents (ints, bools, Warp functions, modules)."""
    return int(hashlib.sha256(_part(table).encode()).hexdigest()[:8], 16) & 0x7FFFFFFF
