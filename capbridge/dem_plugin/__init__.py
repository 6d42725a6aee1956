"""DEM integration: YADE runtime helpers and export of capbridge tables to YADE formats."""
