"""The one exception type bad input raises; the CLI turns it into a single line and exit code 2."""


class InputError(ValueError):
    """Bad user input (scene, config, CLI flag). `field` names what is wrong, e.g. `shapes[2].radius`."""

    def __init__(self, field: str, message: str):
        self.field = field
        self.message = message
        super().__init__(f"{field}: {message}")
