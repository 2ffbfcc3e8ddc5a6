"""The reports as documents: Jinja2 pages in one shared style, and their PDF.

* :func:`render_page` renders a template of ``templates/`` with autoescape on (every
  value is escaped unless a template says otherwise) and the shared style sheet
  ``resources/report.css`` inlined, so that ``index.html`` stands alone.
* :func:`write_pdf` prints a page to PDF with WeasyPrint (an HTML/CSS layout engine,
  pure Python on Pango; Debian 12's ``weasyprint`` package or pip's): A4 pages, a cover,
  one page per room, page numbers in the footer (``@page`` rules of the style sheet).
  Headless browsers are not installed here and matplotlib's ``PdfPages`` would give a stack
  of figures without tables or text flow.
"""
import os

from invrad_wb import constants as C

_TEMPLATES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "templates")
_CSS = "report.css"


class PdfUnavailable(RuntimeError):
    """WeasyPrint cannot be imported: no PDF (the HTML report is still written)."""


def style_sheet():
    """The reports' shared CSS (``resources/report.css``)."""
    with open(os.path.join(C.RESOURCES_DIR, _CSS), encoding="utf-8") as fh:
        return fh.read()


def render_page(template, **context):
    """HTML text of ``templates/<template>`` with ``context`` (autoescaped) and ``css``.

    Parameters
    ----------
    template : str, file name in ``invrad_wb/core/output/templates``
    context : values for the template

    Returns
    -------
    str
    """
    from jinja2 import Environment, FileSystemLoader, StrictUndefined, select_autoescape
    env = Environment(loader=FileSystemLoader(_TEMPLATES), undefined=StrictUndefined,
                      autoescape=select_autoescape(["html", "j2"]), trim_blocks=True,
                      lstrip_blocks=True)
    env.filters["units"] = units
    return env.get_template(template).render(css=style_sheet(), **context)


def units(text):
    """A note as the page writes units: square metres as m² ('24.0 m2' and 'W/m2' in the
    notes the design and locate steps write as plain text, 'm²' in the page's tables)."""
    import re
    return re.sub(r"(\d m|/m)2\b", "\\g<1>²", str(text))


def pdf_engine():
    """The WeasyPrint module, or :class:`PdfUnavailable` naming what to install."""
    try:
        import weasyprint
    except (ImportError, OSError) as exc:       # OSError: Pango missing under it
        raise PdfUnavailable(
            f"no PDF: WeasyPrint cannot be loaded ({exc}); install it with"
            " 'apt-get install weasyprint' (Debian) or 'pip install weasyprint'") from None
    return weasyprint


def write_pdf(html, base_dir, path):
    """Print an HTML page to a PDF file.

    Parameters
    ----------
    html : str, the page
    base_dir : folder that relative links (images) of the page are resolved in
    path : the PDF file (written directly: callers stage it, see the reports)

    Raises
    ------
    PdfUnavailable
        WeasyPrint cannot be imported.
    """
    weasyprint = pdf_engine()
    import logging
    # WeasyPrint logs every CSS property it does not know (screen-only rules) as a warning
    logging.getLogger("weasyprint").setLevel(logging.ERROR)
    logging.getLogger("fontTools").setLevel(logging.ERROR)
    weasyprint.HTML(string=html, base_url=os.path.abspath(base_dir) + os.sep).write_pdf(path)
    return path
