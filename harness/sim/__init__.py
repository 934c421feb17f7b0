"""``Simulator.step``: TEACh's driver actions on a world, as AI2-THOR answers them. ``navgrid`` (where the
agent may stand), ``reach`` (AI2-THOR's reach cylinder), ``clicks`` (which object a click point hits),
``physics`` (state changes and where put-down things come to rest), ``failures`` (AI2-THOR's failure
reasons) and the ``simulator`` that joins them."""
