"""The sub-commands of ``vibrofriction``, one module each (registered in ``cli.COMMANDS``)."""
