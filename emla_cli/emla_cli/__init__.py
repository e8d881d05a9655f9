"""emla_cli: the `emla` command line (emla_cli.cli), one module per subcommand in emla_cli.commands, the
launcher of the ROS 2 graph (emla_cli.launcher) and the plots the commands draw."""
__all__: list[str] = []
