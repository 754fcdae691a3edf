"""The physics every solver reads (issue 37): the spring (:mod:`vifpk.physics.spring`) and the
noise kinds (:mod:`vifpk.physics.noise`), one module each. Imports only vifpk.core and numpy."""
