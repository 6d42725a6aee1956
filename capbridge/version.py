"""capbridge's version (recorded in every table and export it writes)."""
__version__ = "0.2.0"
