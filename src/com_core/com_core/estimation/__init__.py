"""From stamped samples to mass, COM and inertia, in three sub-wings whose imports run
one way: ``recordings`` (any recording, without labels) and ``runs`` (the sequencer's
labelled runs) end in the same ``fits`` (one fit per model). ``runs`` imports only
``fits``; ``recordings`` imports ``fits`` and the bag feed of ``runs``; ``fits`` imports
neither (``test/test_house.py`` checks). Each sub-wing's ``__init__`` names its public
parts. Why three: docs/design.md, Decisions.
"""
