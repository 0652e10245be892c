"""The flag values of the atlas' datasets, light on imports (the variable catalogue reads them)."""

#: Kinds of curves.
CURVE_KINDS = ("grazing", "fold", "neimark_sacker", "flip", "second_contact")
#: Contact laws of the curves.
LAWS = ("piecewise_linear", "regularized")
#: Kinds of codimension-two points.
CODIM2_KINDS = ("cusp", "isola", "fold_flip", "resonance_1_1", "resonance_1_2", "grazing", "second_contact")
#: Regions of a map.
REGIONS = ("no_contact", "impacting", "coexisting", "no_stable_periodic", "not_covered")
#: How a one-contact family of a slice ends: the margins of nnmstop.exact.forced.CONTACT_MARGINS, in order.
END_KINDS = ("contact_duration", "free_duration", "phase_duration", "leaves_stop", "early_impact", "other_stops")
