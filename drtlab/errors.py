"""The one exception type bad input raises; the CLI turns it into a single line and exit code 2."""


class InputError(ValueError):
    """Bad user input (scene, config, CLI flag). `field` names what is wrong, e.g. `shapes[2].radius`."""

    def __init__(self, field: str, message: str):
        self.field = field
        self.message = message
        super().__init__(f"{field}: {message}")


class NonFiniteImageWarning(RuntimeWarning):
    """A render produced NaN or Inf pixels (a value overflowed float32 somewhere in it): the Python
    API warns with this and returns the image; `drtlab render` says so and exits 1."""
