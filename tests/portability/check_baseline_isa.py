#!/usr/bin/env python3
"""Fails when code outside the per-ISA kernels of a binary uses instructions that baseline x86-64
lacks, so that a default build runs on any x86-64 CPU (plx/core/cpu.h).

Only functions whose (demangled) name lies in an `isa_avx2` or `isa_avx512` namespace may use
them: those are the per-ISA kernels, reached only through PLX_ISA_PICK on a CPU that has the ISA.
Anything else that does is either a module still compiled with -march flags, or an inline
function or template instantiated in a per-ISA translation unit under a name that the baseline
code shares (a COMDAT copy the linker may keep for every caller; see plx/core/isa_kernel.h).

    check_baseline_isa.py [--objdump PATH] [--expect-kernels] BINARY

--expect-kernels also requires some isa_avx2 function to use ymm registers, which shows that the
disassembly was read (a dispatched build has such kernels).
"""

import argparse
import re
import subprocess
import sys
from collections import defaultdict

# Registers that baseline x86-64 (SSE2) does not have: 256- and 512-bit vectors, AVX-512 masks.
FORBIDDEN_REGISTER = re.compile(r"%(ymm\d+|zmm\d+|k[0-7])\b")

# Mnemonics beyond SSE2. VEX/EVEX-encoded instructions all start with `v` (the few legacy `v`
# mnemonics, verr/verw and the VMX ones, are excluded). tzcnt is allowed: the compiler emits
# `rep bsf` for baseline code, which objdump shows as tzcnt and older CPUs execute as bsf.
FORBIDDEN_MNEMONICS = {
    # BMI1/2, LZCNT, POPCNT, MOVBE, ADX
    "andn", "bextr", "blsi", "blsmsk", "blsr", "bzhi", "mulx", "pdep", "pext", "rorx", "sarx",
    "shlx", "shrx", "lzcnt", "popcnt", "movbe", "adcx", "adox",
    # SSE3, SSSE3
    "addsubps", "addsubpd", "haddps", "haddpd", "hsubps", "hsubpd", "lddqu", "movddup",
    "movshdup", "movsldup", "pshufb", "palignr", "phaddw", "phaddd", "phaddsw", "phsubw",
    "phsubd", "phsubsw", "pabsb", "pabsw", "pabsd", "psignb", "psignw", "psignd", "pmaddubsw",
    "pmulhrsw",
    # SSE4.1, SSE4.2
    "blendps", "blendpd", "blendvps", "blendvpd", "pblendvb", "pblendw", "dpps", "dppd",
    "insertps", "extractps", "mpsadbw", "movntdqa", "packusdw", "pcmpeqq", "pextrb", "pextrd",
    "pextrq", "pinsrb", "pinsrd", "pinsrq", "pmaxsb", "pmaxsd", "pmaxud", "pmaxuw", "pminsb",
    "pminsd", "pminud", "pminuw", "pmovsxbw", "pmovsxbd", "pmovsxbq", "pmovsxwd", "pmovsxwq",
    "pmovsxdq", "pmovzxbw", "pmovzxbd", "pmovzxbq", "pmovzxwd", "pmovzxwq", "pmovzxdq",
    "pmuldq", "pmulld", "ptest", "roundps", "roundpd", "roundss", "roundsd", "phminposuw",
    "pcmpestri", "pcmpestrm", "pcmpistri", "pcmpistrm", "pcmpgtq", "crc32",
    # AES, CLMUL, SHA
    "aesenc", "aesenclast", "aesdec", "aesdeclast", "aesimc", "aeskeygenassist", "pclmulqdq",
    "sha1rnds4", "sha1nexte", "sha1msg1", "sha1msg2", "sha256rnds2", "sha256msg1",
    "sha256msg2",
}
LEGACY_V_MNEMONICS = {"verr", "verw", "vmcall", "vmlaunch", "vmresume", "vmxoff", "vmxon",
                      "vmread", "vmwrite", "vmptrld", "vmptrst", "vmclear", "vmfunc"}
KERNEL_NAMESPACE = re.compile(r"\bisa_(avx2|avx512)::")
FUNCTION_HEADER = re.compile(r"^[0-9a-f]+ <(.*)>:$")
PREFIXES = r"(?:(?:rex\S*|lock|rep\S*|data16|cs|ds|notrack|bnd)\s+)*"
INSTRUCTION = re.compile(r"^\s+[0-9a-f]+:\s+" + PREFIXES + r"([a-z][a-z0-9.]*)\s*(.*)$")


def forbidden(mnemonic, operands):
    """Why an instruction needs more than baseline x86-64, or None."""
    base = mnemonic.split(".")[0]
    if base.startswith("v") and base not in LEGACY_V_MNEMONICS:
        return "VEX/EVEX instruction"
    if base in FORBIDDEN_MNEMONICS:
        return "beyond SSE2"
    match = FORBIDDEN_REGISTER.search(operands)
    if match:
        return f"register {match.group(1)}"
    return None


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("binary")
    parser.add_argument("--objdump", default="objdump")
    parser.add_argument("--expect-kernels", action="store_true")
    args = parser.parse_args()

    disassembly = subprocess.run(
        [args.objdump, "-d", "--no-show-raw-insn", "-C", args.binary],
        check=True, capture_output=True, text=True).stdout

    leaks = defaultdict(list)  # function -> [(instruction, reason)]
    kernel_uses_ymm = False
    functions = 0
    function = None
    for line in disassembly.splitlines():
        header = FUNCTION_HEADER.match(line)
        if header:
            function = header.group(1)
            functions += 1
            continue
        match = INSTRUCTION.match(line)
        if not match or function is None:
            continue
        mnemonic, operands = match.group(1), match.group(2)
        if KERNEL_NAMESPACE.search(function):
            if "isa_avx2::" in function and "%ymm" in operands:
                kernel_uses_ymm = True
            continue
        reason = forbidden(mnemonic, operands)
        if reason:
            leaks[function].append(f"{mnemonic} {operands}".strip() + f"  ({reason})")

    if functions == 0:
        print(f"no functions found in the disassembly of {args.binary}", file=sys.stderr)
        return 2
    status = 0
    if leaks:
        print(f"{len(leaks)} functions outside the isa_avx2/isa_avx512 kernels use instructions "
              f"that baseline x86-64 lacks:")
        for name in sorted(leaks):
            found = leaks[name]
            more = f"  (+{len(found) - 1} more)" if len(found) > 1 else ""
            print(f"  {name}\n      {found[0]}{more}")
        status = 1
    if args.expect_kernels and not kernel_uses_ymm:
        print("no isa_avx2 function uses ymm registers: the kernels are missing or the "
              "disassembly was not understood")
        status = 1
    if status == 0:
        print(f"{functions} functions checked: only the per-ISA kernels go beyond baseline x86-64")
    return status


if __name__ == "__main__":
    sys.exit(main())
