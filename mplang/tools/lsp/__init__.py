"""`mpc lsp`: the language server for .mp files (pygls, over stdio)."""
