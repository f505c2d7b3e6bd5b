"""What a shipped binary declares as the oldest system it loads on, read from its headers with struct
alone (no binutils, no third-party parser): the tests' independent view of what the build produced.

* Mach-O (macOS): the ``LC_BUILD_VERSION`` load command (0x32): platform, ``minos`` and ``sdk``, each a
  version packed as ``xxxx.yy.zz`` in a uint32 (major << 16 | minor << 8 | patch).  An older binary may
  carry ``LC_VERSION_MIN_MACOSX`` (0x24) instead, same packing.
* ELF (Linux): the newest ``GLIBC_x.y`` version the binary needs, from its version-needed section
  (``SHT_GNU_verneed``): the dynamic loader refuses an older glibc.
* PE (Windows): the optional header's MajorOperatingSystemVersion / MinorOperatingSystemVersion and
  MajorSubsystemVersion / MinorSubsystemVersion, and the names of the DLLs imported.
"""

from __future__ import annotations

import re
import struct

MH_MAGIC_64 = 0xFEEDFACF
FAT_MAGIC = 0xCAFEBABE  # a universal Mach-O: big-endian header and fat_arch table
LC_BUILD_VERSION = 0x32
LC_VERSION_MIN_MACOSX = 0x24
PLATFORM_MACOS = 1
CPU = {0x01000007: "x86_64", 0x0100000C: "arm64"}


def _version(packed):
    return (packed >> 16, (packed >> 8) & 0xFF, packed & 0xFF)


def macho_slices(data: bytes) -> list[tuple[str, int, bytes]]:
    """The thin Mach-O files of a universal one as ``(cpu, align, bytes)`` in the table's order
    (``fat_header``: magic, nfat_arch; ``fat_arch``: cputype, cpusubtype, offset, size, align, all
    big-endian uint32); a thin Mach-O is its own one slice.  Raises ValueError on a slice outside
    the file, misaligned, or whose own header names another cpu."""
    if struct.unpack_from(">I", data, 0)[0] != FAT_MAGIC:
        return [(macho_min_os(data)["cpu"], 0, data)]
    (n,) = struct.unpack_from(">I", data, 4)
    out = []
    for j in range(n):
        cputype, _, offset, size, align = struct.unpack_from(">iiIII", data, 8 + 20 * j)
        if offset % (1 << align) or offset + size > len(data):
            raise ValueError(f"slice {j}: offset {offset}, size {size}, align 2**{align}, file {len(data)} B")
        thin = data[offset:offset + size]
        if struct.unpack_from("<i", thin, 4)[0] != cputype:
            raise ValueError(f"slice {j}: the table says cputype {cputype:#x}, the slice's header another")
        out.append((CPU.get(cputype, hex(cputype)), align, thin))
    return out


def macho_min_os(data: bytes) -> dict:
    """``{"cpu": ..., "platform": int, "minos": (major, minor, patch), "sdk": (...)}`` of a 64-bit
    little-endian Mach-O; raises ValueError when it is not one or declares no minimum."""
    magic, cputype, _, _, ncmds, sizeofcmds = struct.unpack_from("<IiiIII", data, 0)
    if magic != MH_MAGIC_64:
        raise ValueError(f"not a 64-bit little-endian Mach-O (magic {magic:#x})")
    off, end = 32, 32 + sizeofcmds
    for _ in range(ncmds):
        cmd, size = struct.unpack_from("<II", data, off)
        if cmd == LC_BUILD_VERSION:
            platform, minos, sdk = struct.unpack_from("<III", data, off + 8)
            return {"cpu": CPU.get(cputype, hex(cputype)), "platform": platform, "minos": _version(minos),
                    "sdk": _version(sdk)}
        if cmd == LC_VERSION_MIN_MACOSX:
            version, sdk = struct.unpack_from("<II", data, off + 8)
            return {"cpu": CPU.get(cputype, hex(cputype)), "platform": PLATFORM_MACOS,
                    "minos": _version(version), "sdk": _version(sdk)}
        if size < 8 or off + size > end:
            raise ValueError(f"load command at {off} has a bad size {size}")
        off += size
    raise ValueError("no LC_BUILD_VERSION or LC_VERSION_MIN_MACOSX load command")


SHT_GNU_VERNEED = 0x6FFFFFFE


def elf_glibc_versions(data: bytes) -> list[tuple[int, ...]]:
    """Every ``GLIBC_x.y[.z]`` version a 64-bit little-endian ELF needs, sorted (from SHT_GNU_verneed:
    Elf64_Verneed entries, each with its Elf64_Vernaux list, names in the section's linked string table)."""
    if data[:4] != b"\x7fELF" or data[4] != 2 or data[5] != 1:
        raise ValueError("not a 64-bit little-endian ELF")
    e_shoff, = struct.unpack_from("<Q", data, 0x28)
    e_shentsize, e_shnum = struct.unpack_from("<HH", data, 0x3A)
    sections = [struct.unpack_from("<IIQQQQIIQQ", data, e_shoff + i * e_shentsize) for i in range(e_shnum)]
    found = set()
    for _, sh_type, _, _, sh_offset, _, sh_link, sh_info, _, _ in sections:
        if sh_type != SHT_GNU_VERNEED:
            continue
        strtab = sections[sh_link][4]
        off = sh_offset
        for _ in range(sh_info):  # sh_info: the number of Verneed entries
            _, vn_cnt, _, vn_aux, vn_next = struct.unpack_from("<HHIII", data, off)
            aux = off + vn_aux
            for _ in range(vn_cnt):
                _, _, _, vna_name, vna_next = struct.unpack_from("<IHHII", data, aux)
                name = data[strtab + vna_name:data.index(b"\0", strtab + vna_name)].decode()
                m = re.fullmatch(r"GLIBC_(\d+(?:\.\d+)+)", name)
                if m:
                    found.add(tuple(int(x) for x in m.group(1).split(".")))
                aux += vna_next
            off += vn_next
    return sorted(found)


def pe_min_os(data: bytes) -> dict:
    """``{"os": (major, minor), "subsystem": (major, minor), "imports": [dll names], "functions": {dll
    name: [imported function names, "#N" for one by ordinal]}}`` of a PE32+ file.  The imports are read
    from the import directory (IMAGE_IMPORT_DESCRIPTOR: OriginalFirstThunk, TimeDateStamp,
    ForwarderChain, Name, FirstThunk RVAs), the functions from its lookup table (64-bit entries: the top
    bit an ordinal, else the RVA of a hint and the name), all mapped to file offsets through the section
    table."""
    if data[:2] != b"MZ":
        raise ValueError("not a PE file (no MZ)")
    pe, = struct.unpack_from("<I", data, 0x3C)
    if data[pe:pe + 4] != b"PE\0\0":
        raise ValueError("no PE signature")
    coff = pe + 4
    nsections, = struct.unpack_from("<H", data, coff + 2)
    opt_size, = struct.unpack_from("<H", data, coff + 16)
    opt = coff + 20
    if struct.unpack_from("<H", data, opt)[0] != 0x20B:
        raise ValueError("not PE32+")
    os_major, os_minor, _, _, sub_major, sub_minor = struct.unpack_from("<6H", data, opt + 40)
    import_rva, = struct.unpack_from("<I", data, opt + 112 + 8)  # data directory 1: the import table
    sec = opt + opt_size
    table = [struct.unpack_from("<8sIIII", data, sec + 40 * i) for i in range(nsections)]

    def offset(rva):
        for _, vsize, vaddr, rsize, raw in table:
            if vaddr <= rva < vaddr + max(vsize, rsize):
                return raw + rva - vaddr
        raise ValueError(f"RVA {rva:#x} in no section")

    def text(rva):
        o = offset(rva)
        return data[o:data.index(b"\0", o)].decode()

    imports, functions = [], {}
    if import_rva:
        d = offset(import_rva)
        while True:
            lookup_rva, _, _, name_rva, first_thunk = struct.unpack_from("<5I", data, d)
            if name_rva == 0:
                break
            dll = text(name_rva)
            imports.append(dll)
            names, t = [], offset(lookup_rva or first_thunk)
            while True:
                entry, = struct.unpack_from("<Q", data, t)
                if entry == 0:
                    break
                names.append(f"#{entry & 0xFFFF}" if entry >> 63 else text((entry & 0x7FFFFFFF) + 2))
                t += 8
            functions[dll] = names
            d += 20
    return {"os": (os_major, os_minor), "subsystem": (sub_major, sub_minor), "imports": imports,
            "functions": functions}
