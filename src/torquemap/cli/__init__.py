"""The command-line interface: thin wrappers that parse, load, call one library function, write."""
