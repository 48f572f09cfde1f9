"""The command line: the parser, the commands, their arguments."""
