"""The request layer: everything checked, priced and settled before any work.

``prepare`` builds the one request (concrete scene, options, models, tolerance) every front end
hands to the door; ``validate`` checks scenes, options and output paths; ``cost`` prices a run
(seconds, memory) and refuses what is too dear; ``errors`` holds ``InputError``.
"""
