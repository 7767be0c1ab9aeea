"""The document each FreeCAD test works in."""

import FreeCAD
import pytest


@pytest.fixture
def doc(request):
    """A new document named after the test module, closed after the test."""
    document = FreeCAD.newDocument(request.module.__name__.rsplit(".", 1)[-1])
    name = document.Name
    yield document
    if name in FreeCAD.listDocuments():
        FreeCAD.closeDocument(name)
