# Generated from the repository's VERSION file by `make version` (the Makefile
# also passes it to the firmware as FW_VERSION); tests/test_version.py checks
# that the two agree. Edit VERSION, not this file.
__version__ = "0.2.0"
