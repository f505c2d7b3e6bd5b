"""What makes a native FMU a source-code FMU: its C sources under ``sources/`` (placed there by
:func:`orchestration.packaging.native.compiler.build_native_fmu`) and what a tool needs to compile them alone.

* ``sources/fg_identity.h``: the model identifier and the GUID (FMI 3.0: instantiationToken) the glue
  compiles in (``fmu/native/fmi/fg_instance.h`` includes it when neither is given with ``-D``), so
  ``cc -std=c99 -shared -fPIC *.c -o <id>.so -lm`` in ``sources/`` builds a working binary;
* FMI 2.0: ``<SourceFiles>`` in the ``<CoSimulation>`` element of modelDescription.xml (FMI 2.0,
  section 4.3.1), the C files to compile;
* FMI 3.0: ``sources/buildDescription.xml`` (FMI 3.0, section 2.6.1; schema fmi3BuildDescription.xsd):
  one build configuration, one C99 source file set, the math library;
* ``sources/BUILD.txt``: the compiler command, for a person.

Compile with ``-ffp-contract=off`` (clang's default fuses a*b+c into one rounding on targets with FMA,
such as aarch64: the results would then differ from the shipped binaries' in the last bits); gcc in its
ISO C modes (``-std=c99``) does not fuse.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from xml.sax.saxutils import quoteattr

IDENTITY_HEADER = "fg_identity.h"
BUILD_DESCRIPTION = "buildDescription.xml"
COMPILER_OPTIONS = "-ffp-contract=off"


def with_source_files(model_description_xml: str, c_files: Sequence[str]) -> str:
    """The FMI 2.0 model description with ``<SourceFiles>`` (one ``<File>`` per C file, names relative to
    ``sources/``) as the first child of ``<CoSimulation>`` (a model-exchange FMU: ``<ModelExchange>``)."""
    files = "".join(f"\n\t\t\t<File name={quoteattr(n)} />" for n in c_files)
    block = f"\n\t\t<SourceFiles>{files}\n\t\t</SourceFiles>\n\t"
    kind = "CoSimulation" if "<CoSimulation" in model_description_xml else "ModelExchange"
    m = re.search(rf"<{kind}\b([^>]*?)\s*/>", model_description_xml)
    if m:  # <CoSimulation ... />: open it
        return (model_description_xml[:m.start()] + f"<{kind}{m.group(1)}>{block}</{kind}>"
                + model_description_xml[m.end():])
    m = re.search(rf"<{kind}\b[^>]*>", model_description_xml)
    if m is None:
        raise ValueError("the model description has no <CoSimulation> or <ModelExchange> element")
    return model_description_xml[:m.end()] + block + model_description_xml[m.end():]


def build_description(model_identifier: str, c_files: Sequence[str]) -> str:
    """``sources/buildDescription.xml`` of an FMI 3.0 FMU."""
    files = "".join(f"\n\t\t\t<SourceFile name={quoteattr(n)} />" for n in c_files)
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<fmiBuildDescription fmiVersion="3.0">\n'
        f'\t<BuildConfiguration modelIdentifier={quoteattr(model_identifier)} '
        'description="the shared library of the FMU, as shipped in binaries/">\n'
        f'\t\t<SourceFileSet language="C99" compilerOptions="{COMPILER_OPTIONS}">{files}\n'
        '\t\t\t<IncludeDirectory name="." />\n'
        '\t\t</SourceFileSet>\n'
        '\t\t<Library name="m" external="true" description="the C math library (-lm; part of the C '
        'runtime on Windows and macOS)" />\n'
        '\t</BuildConfiguration>\n'
        '</fmiBuildDescription>\n')


def identity_header(model_identifier: str, token: str, defines: Sequence[str] = ()) -> str:
    """``sources/fg_identity.h``: the two macros the glue needs, for a build without ``-D``; ``defines``:
    the build's other ``-D`` flags (``NAME`` or ``NAME=VALUE``, e.g. ``FG_MODEL_EXCHANGE``), the same way."""
    extra = "".join(f"#define {d.replace('=', ' ', 1)}\n" for d in defines)
    return (f"/* {IDENTITY_HEADER} - generated: the identity of this FMU's binary (see fg_instance.h) */\n"
            f"#ifndef FG_IDENTITY_H\n#define FG_IDENTITY_H\n"
            f"#define MODEL_IDENTIFIER {model_identifier}\n"
            f'#define INSTANTIATION_TOKEN "{token}"\n'
            f"{extra}#endif\n")


def build_text(model_identifier: str, c_files: Sequence[str], fmi_major: int) -> str:
    """``sources/BUILD.txt``: how to build the binary from this directory."""
    listed = ("<SourceFiles> in modelDescription.xml" if fmi_major == 2 else BUILD_DESCRIPTION)
    return (f"Build the binary of {model_identifier} from these sources (the C files are listed in "
            f"{listed};\n"
            f"{IDENTITY_HEADER} holds the model identifier and the token, so no -D is needed):\n\n"
            f"  Linux:   cc -std=c99 -O2 -shared -fPIC {COMPILER_OPTIONS} {' '.join(c_files)} "
            f"-o {model_identifier}.so -lm\n"
            f"  macOS:   cc -std=c99 -O2 -shared {COMPILER_OPTIONS} {' '.join(c_files)} "
            f"-o {model_identifier}.dylib\n"
            f"  Windows: cc -std=c99 -O2 -shared {COMPILER_OPTIONS} {' '.join(c_files)} "
            f"-o {model_identifier}.dll\n\n"
            f"and put it into binaries/<platform>/ of the unpacked FMU.\n")
