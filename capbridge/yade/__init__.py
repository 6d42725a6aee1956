"""YADE glue: the CapbridgeEngine, its options and persistence (O.save/O.load), the
native Law2 path, YADE's table files, running YADE scenes."""
