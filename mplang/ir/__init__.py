"""The macro IR every controller family compiles from: the command catalogue is its
instruction set (`catalogue`), `macro` its types, `lower` turns a checked `.mp` unit into
macro lines (expressions through temporaries, constants folded as the device computes), and
`configure` lowers the INIT, INTERRUPTS and TRIGGERS blocks. Below them: `scope` (the build's
names), `fold` (the device arithmetic), `operands` (expressions and command arguments) and
`interrupts` (ON ... CALL wiring, shared by `lower` and `configure`). `mpwriter` goes back:
macro lines to `.mp` statements."""
