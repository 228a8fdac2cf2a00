"""Drawing: where and in what order strokes are drawn, and how they look before they are drawn.

`place` (size, offset, rotation on the page), `order` (stroke order, reversal, seams),
`render` (the preview and simulate pictures, PNG and SVG).
"""
