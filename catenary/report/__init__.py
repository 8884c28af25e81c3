"""What a person reads first: the HTML report's front page (:mod:`.front_page`).

The top layer: it may import every layer below and nothing imports it.
"""
