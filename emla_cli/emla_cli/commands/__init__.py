"""Subcommands of the `emla` command line: each module has HELP, add_arguments(parser) and run(args);
`output` holds what they share for writing results."""
