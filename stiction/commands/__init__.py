"""One module per ``stiction`` subcommand: ``add_arguments(parser)`` and ``run(args) -> int``."""
