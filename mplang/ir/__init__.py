"""The macro IR every controller family compiles from: the command catalogue is its
instruction set (`catalogue`), `macro` its types, `lower` turns a checked `.mp` unit into
macro lines (expressions through temporaries, constants folded as the device computes), and
`configure` lowers the INIT, INTERRUPTS and TRIGGERS blocks. `mpwriter` goes back: macro
lines to `.mp` statements."""
