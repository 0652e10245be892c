"""The pipeline's tasks: the only code that reads the config and files and writes results."""
