"""``mavhelm tune``'s pure half: the identification manoeuvre, the fit of the vehicle's
response, the gains that suit it and their place in a mission file. No I/O here: the runner
that flies the manoeuvre is ``mavhelm.companion.tune``."""
