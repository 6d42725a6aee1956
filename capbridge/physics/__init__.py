"""Physics as small pure functions: closed-form bridge laws, gravity shares, the
coalescence-volume law.  Imports only the core (units, status, validation)."""
