"""Published studies redone: ``capbridge reproduce <study>``.

``miot2021``  Miot et al. (2021), Granular Matter 23:66 -- capillary forces and the
              coalescence of two bridges in a triplet of spheres (:mod:`.miot2021`).
"""
STUDIES = ("miot2021",)
