"""A colour legend drawn with Coin in screen space (GUI only).

The legend is an ``SoSeparator`` holding its own ``SoOrthographicCamera``
(``viewportMapping = LEAVE_ALONE``, so it keeps its place when the window is resized or
the model rotates), a per-vertex coloured ``SoQuadMesh`` for the ramp and ``SoText2``
labels for the range and unit.  It is wrapped in FreeCAD's ``SoSkipBoundingGroup`` when
available so that "Fit all" ignores it.
"""

from pivy import coin

__all__ = ["Legend"]

STEPS = 8


def _skip_bounding_group():
    kind = coin.SoType.fromName("SoSkipBoundingGroup")
    if kind.isBad():
        return coin.SoSeparator()
    return coin.cast(kind.createInstance(), "SoGroup")


def _label(text, x, y, color=(0.0, 0.0, 0.0)):
    sep = coin.SoSeparator()
    translation = coin.SoTranslation()
    translation.translation = (x, y, 0)
    material = coin.SoBaseColor()
    material.rgb = color
    node = coin.SoText2()
    node.string = text
    node.justification = coin.SoText2.RIGHT
    for child in (translation, material, node):
        sep.addChild(child)
    return sep, node


class Legend:
    """Colour bar with min/max labels, title and unit; ``node`` goes in a scene graph."""

    def __init__(self):
        self.node = coin.SoSwitch()
        group = _skip_bounding_group()
        root = coin.SoSeparator()
        camera = coin.SoOrthographicCamera()
        camera.viewportMapping = coin.SoCamera.LEAVE_ALONE
        camera.position = (0, 0, 5)
        camera.height = 2.0
        camera.nearDistance, camera.farDistance = 0.1, 10.0
        light = coin.SoLightModel()
        light.model = coin.SoLightModel.BASE_COLOR
        self._coords = coin.SoCoordinate3()
        self._colors = coin.SoBaseColor()
        binding = coin.SoMaterialBinding()
        binding.value = coin.SoMaterialBinding.PER_VERTEX
        self._mesh = coin.SoQuadMesh()
        self._mesh.verticesPerRow = 2
        self._mesh.verticesPerColumn = STEPS + 1
        font = coin.SoFont()
        font.size = 14
        self._labels = []
        for child in (camera, light, self._coords, binding, self._colors, self._mesh, font):
            root.addChild(child)
        for x, y in ((0.95, 0.45), (0.86, 0.33), (0.86, -0.87)):
            sep, node = _label("", x, y)
            root.addChild(sep)
            self._labels.append(node)
        group.addChild(root)
        self.node.addChild(group)
        self.node.whichChild = coin.SO_SWITCH_ALL

    def update(self, title, low, high, unit, colors):
        """Redraw for the range ``low..high`` with ramp end colours ``colors``."""
        x0, x1, y0, y1 = 0.88, 0.95, -0.85, 0.35
        points, rgb = [], []
        for i in range(STEPS + 1):
            t = i / STEPS
            y = y0 + t * (y1 - y0)
            points += [(x0, y, 0), (x1, y, 0)]
            c = tuple((1 - t) * a + t * b for a, b in zip(*colors))
            rgb += [c, c]
        self._coords.point.setValues(0, len(points), points)
        self._colors.rgb.setValues(0, len(rgb), rgb)
        texts = (title, f"max {high:.4g} {unit}", f"min {low:.4g} {unit}")
        for node, text in zip(self._labels, texts):
            node.string = text

    def show(self, visible):
        self.node.whichChild = coin.SO_SWITCH_ALL if visible else coin.SO_SWITCH_NONE

    @property
    def visible(self):
        return self.node.whichChild.getValue() == coin.SO_SWITCH_ALL
