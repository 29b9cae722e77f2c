"""One module per CLI command: parse the composed config, call the library, print."""
