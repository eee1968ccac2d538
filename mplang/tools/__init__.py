"""Tools around the language and the families: the formatter, the language server, plots,
the project file, and the generators of docs and editor grammars."""
