"""An example chronofuse plugin: :mod:`.servo` (a proportional servo) and :mod:`.detector` (a jump detector)."""
