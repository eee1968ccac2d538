"""One module per `mpc` command, each defining `command` (see `mplang.cli`)."""
