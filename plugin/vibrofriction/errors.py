"""Errors that mean "the user's input is wrong": the CLI prints them as one line, exit code 2."""


class InputError(ValueError):
    """Bad input; the message names what is wrong and how to fix it."""
