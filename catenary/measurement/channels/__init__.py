"""What measuring cars and crews record besides the contact-wire height.

:mod:`.quantities` names each measurable quantity and gives its value from the per-span
parameters (the campaign's truth and the model's samples alike); :mod:`.wear` relates the CW's
residual thickness to the fraction of its section lost; :mod:`.observations` holds one span
type's measurements and their log-density jointly with W.
"""
