"""Errors that invrad raises for bad input or a missing device.

Every error names what was wrong (file, face, object, value) so that a user can fix it.
They derive from ``InvradError`` so that the CLI and the workbench can report them
without a traceback, and from the matching built-in type so callers may catch either.
"""


class InvradError(Exception):
    """Base class of all errors invrad reports to a user."""


class SceneError(InvradError, ValueError):
    """A scene (mesh, targets, rooms) is malformed.

    Parameters
    ----------
    message : str
        What is wrong.
    source : str, optional
        The file or object the scene came from; prefixed to the message.
    """

    def __init__(self, message, source=None):
        self.source = source
        super().__init__(f"{source}: {message}" if source else message)


class LuminaireError(InvradError, ValueError):
    """A luminaire description (JSON, document object) is malformed."""


class SettingsError(InvradError, ValueError):
    """An option has a value outside its allowed range."""


class DeviceError(InvradError, RuntimeError):
    """No usable OpenCL platform/device, or a kernel failed to build or run."""


class Cancelled(InvradError):
    """A long run was cancelled by the user (progress callback returned False)."""
