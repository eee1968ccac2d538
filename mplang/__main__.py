"""`python -m mplang` is `mpc`."""

from mplang.cli import main

main()
