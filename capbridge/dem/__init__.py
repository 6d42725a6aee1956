"""DEM physics in numpy, no YADE: bridges and the liquid ledger, neighbours (periodic
cells), walls, coalescence detection, liquid clusters, gravity on the liquid, VTK."""
