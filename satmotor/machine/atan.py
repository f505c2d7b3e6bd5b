"""The arc tangent of the arctan magnetizing curve: cheaper than libm's in C, the same floats in both.

:func:`atan` is the specification of the C core's ``sm_atan`` (``fmu/native/core/sm_atan.c``): the
same operations in the same order, so the same floats, on every platform (``math.atan`` calls the
platform's libm, whose last bit differs between glibc, the UCRT and macOS).  Its error is below
0.62 ulp of the exact arc tangent (the worst of 2 10^6 points: 0.617 ulp, at x = 0.1018); it differs
from glibc's ``math.atan`` by one ulp on about 1.5 % of the curve's arguments (0 to 8), never by
more (``tests/test_atan.py``).

* ``|x| < 2**-28``: ``x`` (the next term, ``x**3 / 3``, is below half an ulp of ``x``).
* ``|x| < 1/16``: the Taylor polynomial ``x - x**3/3 + ... - x**15/15`` (next term below ``2**-64 x``).
* ``|x| <= 4``: with ``c = k/64`` the nearest multiple of 1/64, ``atan(a) = atan(c) + atan(t)``,
  ``t = (a - c) / (1 + a c)``, ``|t| <= 1/128``, ``atan(t) = t - t**3/3 + t**5/5 - t**7/7`` (next
  term below ``2**-59 t``); ``atan(c)`` from a table as the double nearest to it plus the double
  nearest to the rest.
* ``|x| > 4``: with ``c = k/64`` the nearest multiple of 1/64 to ``1/a``,
  ``atan(a) = pi/2 - atan(c) - atan(t)``, ``t = (1/a - c) / (1 + c/a) = (1 - a c) / (a + c)``, the same
  polynomial and a table of ``pi/2 - atan(c)``.
* ``|x| > 2**60``: ``pi/2`` rounded (the exact value is within ``2**-60`` of it).

Everything is scaled by 64 (exact): ``t = (64 a - 64 c) / (64 + a (64 c))``; ``64 c`` is an integer,
``64 a - 64 c`` is exact, and ``64 a`` is rounded to the nearest integer as
``(64 a + 1.5 2**52) - 1.5 2**52``.
"""

from __future__ import annotations

import math

__all__ = ["atan", "atan2", "ATAN_K64", "ACOT_K64", "COEFFICIENTS", "ATAN2_CONSTANTS"]

#: ``atan(k / 64)`` for k = 0..256 as (hi, lo): hi the nearest double, lo the nearest double to the rest
ATAN_K64 = tuple((float.fromhex(h), float.fromhex(lo)) for h, lo in (
    ("0x0.0p+0", "0x0.0p+0"), ("0x1.fff555bbb729bp-7", "-0x1.220c39d4dff50p-61"),
    ("0x1.ffd55bba97625p-6", "-0x1.5ec431444912cp-60"), ("0x1.7fb818430da2ap-5", "-0x1.86ef8f794f105p-63"),
    ("0x1.ff55bb72cfdeap-5", "-0x1.c934d86d23f1dp-60"), ("0x1.3f59f0e7c559dp-4", "0x1.ac4ce285df847p-58"),
    ("0x1.7ee182602f10fp-4", "-0x1.cfb654c0c3d98p-58"), ("0x1.be39ebe6f07c3p-4", "0x1.f7b8f29a05987p-58"),
    ("0x1.fd5ba9aac2f6ep-4", "-0x1.cd37686760c17p-59"), ("0x1.1e1fafb043727p-3", "-0x1.b485914dacf8cp-59"),
    ("0x1.3d6eee8c6626cp-3", "0x1.61a3b0ce9281bp-57"), ("0x1.5c9811e3ec26ap-3", "-0x1.054ab2c010f3dp-58"),
    ("0x1.7b97b4bce5b02p-3", "0x1.347b0b4f881cap-58"), ("0x1.9a6a8e96c8626p-3", "0x1.cf601e7b4348ep-59"),
    ("0x1.b90d7529260a2p-3", "0x1.17b10d2e0e5abp-61"), ("0x1.d77d5df205736p-3", "0x1.c648d1534597ep-57"),
    ("0x1.f5b75f92c80ddp-3", "0x1.8ab6e3cf7afbdp-57"), ("0x1.09dc597d86362p-2", "0x1.62e47390cb865p-56"),
    ("0x1.18bf5a30bf178p-2", "0x1.30ca4748b1bf9p-57"), ("0x1.278372057ef46p-2", "-0x1.077cdd36dfc81p-56"),
    ("0x1.362773707ebccp-2", "-0x1.963a544b672d8p-57"), ("0x1.44aa436c2af0ap-2", "-0x1.5d5e43c55b3bap-56"),
    ("0x1.530ad9951cd4ap-2", "-0x1.2566480884082p-57"), ("0x1.614840309cfe2p-2", "-0x1.a725715711f00p-56"),
    ("0x1.6f61941e4def1p-2", "-0x1.c63aae6f6e918p-56"), ("0x1.7d5604b63b3f7p-2", "0x1.69c885c2b249ap-56"),
    ("0x1.8b24d394a1b25p-2", "0x1.b6d0ba3748fa8p-56"), ("0x1.98cd5454d6b18p-2", "0x1.9e6c988fd0a77p-56"),
    ("0x1.a64eec3cc23fdp-2", "-0x1.24dec1b50b7ffp-56"), ("0x1.b3a911da65c6cp-2", "0x1.ae187b1ca5040p-56"),
    ("0x1.c0db4c94ec9f0p-2", "-0x1.cc1ce70934c34p-56"), ("0x1.cde53432c1351p-2", "-0x1.a2cfa4418f1adp-56"),
    ("0x1.dac670561bb4fp-2", "0x1.a2b7f222f65e2p-56"), ("0x1.e77eb7f175a34p-2", "0x1.0e53dc1bf3435p-56"),
    ("0x1.f40dd0b541418p-2", "-0x1.a3992dc382a23p-57"), ("0x1.0039c73c1a40cp-1", "-0x1.b32c949c9d593p-55"),
    ("0x1.0657e94db30d0p-1", "-0x1.d5b495f6349e6p-56"), ("0x1.0c6145b5b43dap-1", "0x1.974fa13b5404fp-58"),
    ("0x1.1255d9bfbd2a9p-1", "-0x1.2bdaee1c0ee35p-58"), ("0x1.1835a88be7c13p-1", "0x1.c621cec00c301p-55"),
    ("0x1.1e00babdefeb4p-1", "-0x1.928df287a668fp-58"), ("0x1.23b71e2cc9e6ap-1", "0x1.c421c9f38224ep-57"),
    ("0x1.2958e59308e31p-1", "-0x1.09e73b0c6c087p-56"), ("0x1.2ee628406cbcap-1", "0x1.c5d5e9ff0cf8dp-55"),
    ("0x1.345f01cce37bbp-1", "0x1.1021137c71102p-55"), ("0x1.39c391cd4171ap-1", "-0x1.2304331d8bf46p-55"),
    ("0x1.3f13fb89e96f4p-1", "0x1.ecf8b492644f0p-56"), ("0x1.445065b795b56p-1", "-0x1.f76d0163f79c8p-56"),
    ("0x1.4978fa3269ee1p-1", "0x1.2419a87f2a458p-56"), ("0x1.4e8de5bb6ec04p-1", "0x1.4a33dbeb3796cp-55"),
    ("0x1.538f57b89061fp-1", "-0x1.1bb74abda520cp-55"), ("0x1.587d81f732fbbp-1", "-0x1.5e5c9d8c5a950p-56"),
    ("0x1.5d58987169b18p-1", "0x1.0028e4bc5e7cap-57"), ("0x1.6220d115d7b8ep-1", "-0x1.2b785350ee8c1p-57"),
    ("0x1.66d663923e087p-1", "-0x1.6ea6febe8bbbap-56"), ("0x1.6b798920b3d99p-1", "-0x1.a80386188c50ep-55"),
    ("0x1.700a7c5784634p-1", "-0x1.8c34d25aadef6p-56"), ("0x1.748978fba8e0fp-1", "0x1.7b2a6165884a1p-59"),
    ("0x1.78f6bbd5d315ep-1", "0x1.406a089803740p-55"), ("0x1.7d528289fa093p-1", "0x1.560821e2f3aa9p-55"),
    ("0x1.819d0b7158a4dp-1", "-0x1.bf76229d3b917p-56"), ("0x1.85d69576cc2c5p-1", "0x1.6b66e7fc8b8c3p-57"),
    ("0x1.89ff5ff57f1f8p-1", "-0x1.55b9a5e177a1bp-55"), ("0x1.8e17aa99cc05ep-1", "-0x1.ec182ab042f61p-56"),
    ("0x1.921fb54442d18p-1", "0x1.1a62633145c07p-55"), ("0x1.9617bfeebaf28p-1", "0x1.0032c8866f9b2p-56"),
    ("0x1.9a000a935bd8ep-1", "0x1.59411df0dccefp-56"), ("0x1.9dd8d51585769p-1", "-0x1.ae877ffec0468p-55"),
    ("0x1.a1a25f2c82506p-1", "-0x1.8b4c3611182fcp-57"), ("0x1.a55ce84fecd16p-1", "-0x1.21ee7dfa97e23p-55"),
    ("0x1.a908afa5b1d4ap-1", "-0x1.5d7be5d5f808bp-56"), ("0x1.aca5f3f19ab96p-1", "0x1.e8e23fc4ff624p-55"),
    ("0x1.b034f38649c88p-1", "-0x1.be88d6936f833p-55"), ("0x1.b3b5ec3794397p-1", "-0x1.2985d9907b080p-55"),
    ("0x1.b7291b4e25bdap-1", "-0x1.c49cc26e63660p-56"), ("0x1.ba8ebd7c5a191p-1", "0x1.e58aede56b11ep-55"),
    ("0x1.bde70ed439fe7p-1", "-0x1.a2b56372c05efp-56"), ("0x1.c1324abe8915dp-1", "0x1.5de7930719b20p-61"),
    ("0x1.c470abf2d3d01p-1", "0x1.6a61dbf199479p-56"), ("0x1.c7a26c706c612p-1", "-0x1.09a8c1f8a4817p-56"),
    ("0x1.cac7c57846f9ep-1", "0x1.0dae13ad18a6bp-55"), ("0x1.cde0ef87a615dp-1", "0x1.88b5df85eda52p-56"),
    ("0x1.d0ee2253886a6p-1", "0x1.2c9f73793ddedp-55"), ("0x1.d3ef94c4cabf9p-1", "0x1.ea50304a31a71p-57"),
    ("0x1.d6e57cf4f0acap-1", "-0x1.763b9456ae66ep-55"), ("0x1.d9d0102b87e53p-1", "0x1.9dff587921d15p-55"),
    ("0x1.dcaf82dc1a6f4p-1", "-0x1.f99cb3ddd4790p-55"), ("0x1.df8408a4a4bf5p-1", "0x1.0f428b385436fp-55"),
    ("0x1.e24dd44c855d1p-1", "0x1.f7ac612ab33d8p-55"), ("0x1.e50d17c3dc497p-1", "-0x1.844a35b61a4b4p-55"),
    ("0x1.e7c2042350f87p-1", "-0x1.0e14d8d5a7dd8p-57"), ("0x1.ea6cc9ac363efp-1", "0x1.64f83238896e5p-58"),
    ("0x1.ed0d97c9041c9p-1", "-0x1.2629e3b5da490p-58"), ("0x1.efa49d0e1fcefp-1", "0x1.85c3eaf843caap-55"),
    ("0x1.f232073aeb172p-1", "-0x1.5f5b3a2cdfc2cp-55"), ("0x1.f4b6033b14105p-1", "-0x1.c5354f363c7eep-58"),
    ("0x1.f730bd281f69bp-1", "0x1.007887af0cbbdp-56"), ("0x1.f9a2604b273d7p-1", "0x1.59fb0e0020faap-55"),
    ("0x1.fc0b171ec926cp-1", "-0x1.3337369af334fp-58"), ("0x1.fe6b0b513e96ap-1", "-0x1.82c681ffe40a2p-56"),
    ("0x1.006132e34d617p+0", "0x1.b343dfa868d93p-54"), ("0x1.0188a74d94efcp+0", "-0x1.de8df32afb52dp-54"),
    ("0x1.02abf692f6d0cp+0", "-0x1.7e03a29351e05p-54"), ("0x1.03cb33fd99ad1p+0", "0x1.97daa58fd9fa9p-54"),
    ("0x1.04e67277a01d7p+0", "0x1.7115496c13eb6p-57"), ("0x1.05fdc48c884c5p+0", "0x1.1c07d0e3c5400p-54"),
    ("0x1.07113c6a93a21p+0", "0x1.c2bc4d3a3e69fp-56"), ("0x1.0820ebe435222p+0", "-0x1.f36f8ddb2aea1p-54"),
    ("0x1.092ce471853ccp+0", "0x1.269f9b3e200c2p-55"), ("0x1.0a353731b9f23p+0", "0x1.95b45bbe0eb51p-55"),
    ("0x1.0b39f4eca23aep+0", "0x1.25934545c016cp-54"), ("0x1.0c3b2e1423c0fp+0", "-0x1.ac7ddfb7312b5p-55"),
    ("0x1.0d38f2c5ba09fp+0", "-0x1.bd0dc231bfd70p-54"), ("0x1.0e3352cbf6450p+0", "-0x1.4e55e38fb33b0p-54"),
    ("0x1.0f2a5d9fff026p+0", "0x1.e6ac2e9161719p-55"), ("0x1.101e226b0f2b4p+0", "-0x1.ca14e83b1fd9ap-55"),
    ("0x1.110eb007f39f7p+0", "-0x1.12b2ff85e5500p-54"), ("0x1.11fc150486eeap+0", "0x1.b640c9c014a5ap-54"),
    ("0x1.12e65fa32aaedp+0", "-0x1.f25b08b14d8d6p-54"), ("0x1.13cd9ddc3dfe6p+0", "0x1.00949f8187484p-56"),
    ("0x1.14b1dd5f90ce1p+0", "-0x1.212d570a63fa2p-56"), ("0x1.15932b95d395fp+0", "-0x1.ba87ea99b85f1p-54"),
    ("0x1.167195a203265p+0", "0x1.1a5aca105c6aep-54"), ("0x1.174d2862d04ccp+0", "0x1.dff7f9a86ea82p-54"),
    ("0x1.1825f074030d9p+0", "-0x1.9523f0af0d3b5p-58"), ("0x1.18fbfa2fd93b8p+0", "0x1.6fe2c91a1ae8dp-55"),
    ("0x1.19cf51b0603ddp+0", "-0x1.4b79cf12e503dp-55"), ("0x1.1aa002d0c9dabp+0", "0x1.b3a673c04199ap-55"),
    ("0x1.1b6e192ebbe44p+0", "0x1.b1b466a88828ep-54"), ("0x1.1c39a02b9aa9bp+0", "0x1.a62db5b691b8ep-55"),
    ("0x1.1d02a2edce14fp+0", "0x1.d0a3b2bae2099p-56"), ("0x1.1dc92c6201617p+0", "0x1.2c52a8a985da5p-55"),
    ("0x1.1e8d473c5d5cap+0", "0x1.40b5b2505c143p-54"), ("0x1.1f4efdf9bd254p+0", "0x1.2e7fa3438c855p-55"),
    ("0x1.200e5ae0dd61dp+0", "0x1.bed3cdd901e18p-55"), ("0x1.20cb680385ea4p+0", "0x1.e2bd9767bfa8bp-54"),
    ("0x1.21862f3fade36p+0", "0x1.4887628d68748p-54"), ("0x1.223eba409a4dap+0", "-0x1.938ca1e2a10c4p-60"),
    ("0x1.22f5127ff70b5p+0", "0x1.4a430e2d0a41ep-55"), ("0x1.23a94146ea64ap+0", "-0x1.b9c2154587b09p-54"),
    ("0x1.245b4faf23111p+0", "-0x1.bcadba0fe318bp-54"), ("0x1.250b46a3e0d15p+0", "0x1.653b67d14a383p-54"),
    ("0x1.25b92ee2f7a49p+0", "-0x1.75e638d53460ap-54"), ("0x1.266510fdcda60p+0", "-0x1.8ae0ea26f0f82p-54"),
    ("0x1.270ef55a53a25p+0", "-0x1.a66b1af5f84fbp-54"), ("0x1.27b6e433f8732p+0", "-0x1.f259ad8e7a574p-56"),
    ("0x1.285ce59c97320p+0", "-0x1.75b26f6f4d78fp-54"), ("0x1.2901017d6053bp+0", "0x1.fb871a0f02f5ap-56"),
    ("0x1.29a33f97bdbeap+0", "0x1.20768f82d028dp-54"), ("0x1.2a43a78631ee9p+0", "-0x1.0166a9fd72ffdp-54"),
    ("0x1.2ae240bd32395p+0", "-0x1.fd6bc679da199p-54"), ("0x1.2b7f128bfc488p+0", "-0x1.41ac5692d0a49p-54"),
    ("0x1.2c1a241d66dc3p+0", "0x1.82b2d58b6a8e9p-54"), ("0x1.2cb37c78adeb4p+0", "0x1.8f3cd516440c2p-58"),
    ("0x1.2d4b22823a35cp+0", "0x1.cf7b124d9fd08p-56"), ("0x1.2de11cfc645f5p+0", "-0x1.d9498f7e33355p-54"),
    ("0x1.2e75728833a54p+0", "0x1.16e3ef7326bdap-56"), ("0x1.2f0829a618470p+0", "0x1.d96ef2bed791dp-54"),
    ("0x1.2f9948b6a1b4cp+0", "0x1.22febbf47b080p-55"), ("0x1.3028d5fb309a3p+0", "0x1.69e83498ed4b0p-57"),
    ("0x1.30b6d796a4da8p+0", "0x1.6254cb03bb199p-54"), ("0x1.3143538e07925p+0", "0x1.22952867e8b27p-54"),
    ("0x1.31ce4fc931347p+0", "0x1.39a6d04c1b60bp-54"), ("0x1.3257d2136bd69p+0", "0x1.875234e0f45aap-54"),
    ("0x1.32dfe01c11c21p+0", "0x1.cb1af39d75eb5p-54"), ("0x1.33667f77285d8p+0", "-0x1.9165a5f117c8bp-55"),
    ("0x1.33ebb59df782bp+0", "-0x1.02b3d3b7bf8dcp-54"), ("0x1.346f87ef9d55dp+0", "-0x1.f0452045d6166p-58"),
    ("0x1.34f1fbb19eb09p+0", "0x1.80d79b4cf61d5p-55"), ("0x1.3573161074351p+0", "0x1.ff4108ba66864p-55"),
    ("0x1.35f2dc20141bbp+0", "-0x1.f41f13d3ea682p-54"), ("0x1.367152dc78ce5p+0", "-0x1.367c8f09402aap-54"),
    ("0x1.36ee7f2a24644p+0", "-0x1.2c820975621fbp-54"), ("0x1.376a65d6a1100p+0", "0x1.3d8d7bdd03293p-58"),
    ("0x1.37e50b98fe91cp+0", "0x1.7c4f65ff85e9ep-54"), ("0x1.385e75124cbfap+0", "0x1.99eb525b29b81p-54"),
    ("0x1.38d6a6ce13353p+0", "-0x1.12c77e8a80f5cp-55"), ("0x1.394da542c63b1p+0", "-0x1.bbed989d6b72ap-57"),
    ("0x1.39c374d238f7bp+0", "-0x1.0e10bce7c08c4p-57"), ("0x1.3a3819ca0cf8ep+0", "-0x1.d1a69d1ff2cf1p-55"),
    ("0x1.3aab98641f26bp+0", "-0x1.dc349cc175bc7p-55"), ("0x1.3b1df4c6f22f4p+0", "-0x1.e2bc25f9f39d7p-54"),
    ("0x1.3b8f3306167a9p+0", "-0x1.15725c9547d04p-54"), ("0x1.3bff57228fb5dp+0", "0x1.511b928b4c626p-59"),
    ("0x1.3c6e650b38047p+0", "0x1.6b63b358e746dp-54"), ("0x1.3cdc609d20e5bp+0", "0x1.e158a27cb7c2dp-54"),
    ("0x1.3d494da3f1dcap+0", "-0x1.39e5cc1bf2c1bp-54"), ("0x1.3db52fda44e83p+0", "-0x1.e08007607544ap-59"),
    ("0x1.3e200aea00d99p+0", "-0x1.4794dda3dc8fbp-54"), ("0x1.3e89e26cb194bp+0", "-0x1.4e1348ce1b7ecp-55"),
    ("0x1.3ef2b9ebde493p+0", "0x1.0ab7d20ab732ap-54"), ("0x1.3f5a94e15daf7p+0", "-0x1.c144454640eb0p-54"),
    ("0x1.3fc176b7a8560p+0", "-0x1.441a3bd3f1083p-59"), ("0x1.402762ca290c8p+0", "0x1.c81b4b507b56cp-55"),
    ("0x1.408c5c658b763p+0", "-0x1.c066d31f57e75p-55"), ("0x1.40f066c808d09p+0", "0x1.7864728af14dfp-54"),
    ("0x1.41538521b2f98p+0", "0x1.b0a24edb2ee98p-57"), ("0x1.41b5ba94bdbe9p+0", "0x1.6bbd4000248b9p-63"),
    ("0x1.42170a35c681ap+0", "0x1.e5c774907e6dbp-55"), ("0x1.4277770c1a3c4p+0", "-0x1.0aa7cf09194acp-55"),
    ("0x1.42d70411f9ec1p+0", "0x1.2b08db7f10896p-55"), ("0x1.4335b434dd72bp+0", "-0x1.988e55ce1ea75p-55"),
    ("0x1.43938a55b4f1dp+0", "0x1.1ff9682e290acp-54"), ("0x1.43f0894928ae2p+0", "-0x1.563bd4f2bf534p-54"),
    ("0x1.444cb3d7d780cp+0", "0x1.84edbdae1963fp-54"), ("0x1.44a80cbe93e21p+0", "0x1.aa08da176e197p-55"),
    ("0x1.450296ae9f949p+0", "-0x1.cfd6fc36c6974p-54"), ("0x1.455c544de5f9ep+0", "0x1.89941b6d451d2p-54"),
    ("0x1.45b54837351a0p+0", "0x1.9e4a72eedacc4p-56"), ("0x1.460d74fa7563bp+0", "-0x1.d6201b3eec51ep-56"),
    ("0x1.4664dd1ce02f9p+0", "0x1.38ecc63a07d2dp-54"), ("0x1.46bb8319350cbp+0", "0x1.c1205cbcfe894p-54"),
    ("0x1.4711695fedde2p+0", "-0x1.369e22089162cp-55"), ("0x1.4766925771d11p+0", "-0x1.2a80843ece68cp-54"),
    ("0x1.47bb005c4732dp+0", "0x1.a2f98d0b4820dp-54"), ("0x1.480eb5c1442d6p+0", "0x1.e1f7e554d81fbp-56"),
    ("0x1.4861b4cfbe710p+0", "-0x1.567d3d25932d1p-57"), ("0x1.48b3ffc7b9d26p+0", "-0x1.0d696aa5da75bp-54"),
    ("0x1.490598e015e2ep+0", "0x1.e07def52831b8p-54"), ("0x1.49568246ba8a0p+0", "0x1.709dbd05ce62dp-54"),
    ("0x1.49a6be20c3a52p+0", "0x1.61f86cbdae1abp-54"), ("0x1.49f64e8aabb4cp+0", "-0x1.5c63158227ab5p-55"),
    ("0x1.4a453598759c0p+0", "-0x1.666bc3f7a196ep-55"), ("0x1.4a937555d578ep+0", "0x1.6d94a35991c0bp-54"),
    ("0x1.4ae10fc6589a5p+0", "-0x1.3b03e8a27f555p-54"), ("0x1.4b2e06e58c993p+0", "-0x1.2e12bc29e6b08p-54"),
    ("0x1.4b7a5ca7259aap+0", "-0x1.ec80f282dc460p-54"), ("0x1.4bc612f723bf5p+0", "0x1.bbe0d14b70c4bp-54"),
    ("0x1.4c112bb9f7c63p+0", "0x1.f746650006c33p-57"), ("0x1.4c5ba8cca6e5ep+0", "-0x1.9efc541a24c7fp-54"),
    ("0x1.4ca58c04ede32p+0", "0x1.144de97a969fcp-55"), ("0x1.4ceed73163682p+0", "0x1.cbb3863f2c17bp-56"),
    ("0x1.4d378c1999a0dp+0", "-0x1.c857a639541c8p-57"), ("0x1.4d7fac7e3f217p+0", "0x1.0dd9ad97af705p-54"),
    ("0x1.4dc73a193f1b4p+0", "0x1.12518d76d3566p-54"), ("0x1.4e0e369de0e34p+0", "0x1.44b357f575649p-58"),
    ("0x1.4e54a3b8e6cf8p+0", "-0x1.546673bfb75f0p-55"), ("0x1.4e9a8310ac6ecp+0", "0x1.020e29e8bc10cp-54"),
    ("0x1.4edfd645441e7p+0", "-0x1.f67eaeec21278p-54"), ("0x1.4f249ef094022p+0", "-0x1.598d4a07c632dp-55"),
    ("0x1.4f68dea672617p+0", "0x1.934f9f2b0020ep-54"), ("0x1.4fac96f4c16eap+0", "0x1.2d7ad8c0660efp-54"),
    ("0x1.4fefc9638a79fp+0", "0x1.ca0501d485c89p-54"), ("0x1.5032777518958p+0", "-0x1.5d5d815252b26p-56"),
    ("0x1.5074a2a612ac3p+0", "-0x1.70b6f0046b390p-55"), ("0x1.50b64c6d950fbp+0", "-0x1.5b6f13ac0b13dp-54"),
    ("0x1.50f7763d4a801p+0", "-0x1.d0bda250c54e3p-54"), ("0x1.5138218184b07p+0", "-0x1.839aa790352aap-54"),
    ("0x1.51784fa1544bap+0", "-0x1.236e3c857c019p-54"), ("0x1.51b801fea07b9p+0", "0x1.a40e735a51dc7p-57"),
    ("0x1.51f739f63df6ap+0", "-0x1.34fffe9d872fbp-54"), ("0x1.5235f8e005952p+0", "0x1.382f68f350418p-54"),
    ("0x1.5274400eea72bp+0", "-0x1.c8ca264844338p-54"), ("0x1.52b210d10f9c9p+0", "-0x1.31c07a21fe319p-54"),
    ("0x1.52ef6c6fdd517p+0", "-0x1.ef7a6346bb398p-54"), ("0x1.532c543015d36p+0", "-0x1.592aed4431c0dp-56"),
    ("0x1.5368c951e9cfdp+0", "-0x1.96f47948a99f1p-54"),
))

#: ``pi/2 - atan(k / 64)`` for k = 0..16, as :data:`ATAN_K64`
ACOT_K64 = tuple((float.fromhex(h), float.fromhex(lo)) for h, lo in (
    ("0x1.921fb54442d18p+0", "0x1.1a62633145c07p-54"), ("0x1.8e1fca98cb633p+0", "0x1.1299ee93be016p-56"),
    ("0x1.8a205fd558740p+0", "-0x1.30228c09a91b4p-54"), ("0x1.8621f4822a647p+0", "-0x1.26d12837ecc05p-57"),
    ("0x1.82250768ac529p+0", "-0x1.e78c96d05afcbp-58"), ("0x1.7e2a1635c67bep+0", "0x1.bf9d9508e7c82p-54"),
    ("0x1.7a319d1e3fe07p+0", "0x1.775dc87d51fe0p-54"), ("0x1.763c1685d3c9cp+0", "0x1.d736a03d2b373p-57"),
    ("0x1.7249faa996a21p+0", "0x1.a8cc1e7480c68p-54"), ("0x1.6e5bbf4e3a633p+0", "0x1.a8068fbbb3283p-54"),
    ("0x1.6a71d772b60cbp+0", "-0x1.11d212e88c8fdp-54"), ("0x1.668cb307c54cbp+0", "0x1.55b872ea367d6p-57"),
    ("0x1.62acbeaca61b8p+0", "0x1.c6ac9f134fa91p-60"), ("0x1.5ed2637169c54p+0", "-0x1.f4189dc29459ep-54"),
    ("0x1.5afe069f1e104p+0", "0x1.8330116e9a3b9p-58"), ("0x1.5730098602231p+0", "0x1.e1994906dd0d7p-54"),
    ("0x1.5368c951e9cfdp+0", "-0x1.96f47948a99f1p-54"),
))

#: ``(-1)**n / (2 n + 1)`` for n = 1..7, the Taylor coefficients of ``atan(t) / t`` in ``t**2``
COEFFICIENTS = tuple(float.fromhex(c) for c in (
    "-0x1.5555555555555p-2", "0x1.999999999999ap-3", "-0x1.2492492492492p-3", "0x1.c71c71c71c71cp-4",
    "-0x1.745d1745d1746p-4", "0x1.3b13b13b13b14p-4", "-0x1.1111111111111p-4"))

_C1, _C2, _C3, _C4, _C5, _C6, _C7 = COEFFICIENTS
# the tables keyed by the float k (a dict lookup is cheaper in CPython than int(k) and two indexings;
# the C indexes its arrays with (int)k: the same entries)
_ATAN = {float(k): pair for k, pair in enumerate(ATAN_K64)}
_ACOT = {float(k): pair for k, pair in enumerate(ACOT_K64)}
# for the copy of the main branch in magnetics.ArctanCurve.solve
TABLE, C1, C2, C3 = _ATAN, _C1, _C2, _C3
_ROUND = 6755399441055744.0  # 1.5 2**52; (y + _ROUND) - _ROUND: y rounded to an integer, for 0 <= y < 2**51
ROUND = _ROUND
TINY = _TINY = 2.0**-28
HUGE = _HUGE = 2.0**60
# atan2's constants: the doubles nearest to pi, pi/2, pi/4 and 3 pi/4, and the double nearest to pi - _PI
_PI = float.fromhex("0x1.921fb54442d18p+1")
_PI_LO = float.fromhex("0x1.1a62633145c07p-53")
_PI_2 = float.fromhex("0x1.921fb54442d18p+0")
_PI_4 = float.fromhex("0x1.921fb54442d18p-1")
_PI_3_4 = float.fromhex("0x1.2d97c7f3321d2p+1")
#: (C name, value, meaning) of :func:`atan2`'s constants, for the C's generated header
ATAN2_CONSTANTS = (("PI", _PI, "pi rounded"), ("PI_LO", _PI_LO, "pi - SM_ATAN2_PI rounded"),
                   ("PI_2", _PI_2, "pi/2 rounded"), ("PI_4", _PI_4, "pi/4 rounded"),
                   ("PI_3_4", _PI_3_4, "3 pi/4 rounded"))


def atan(x):
    """The arc tangent of ``x`` [rad], the floats of the C core's ``sm_atan``: below 0.62 ulp from
    the exact value, odd (``-0.0`` kept), ``+-pi/2`` at ``+-inf``, NaN for NaN."""
    a = x if x >= 0.0 else -x
    if 0.0625 <= a <= 4.0:
        y = a * 64.0
        n = (y + _ROUND) - _ROUND
        hi, lo = _ATAN[n]
        t = (y - n) / (64.0 + a * n)
        z = t * t
        w = t * z * ((_C1 + z * _C2) + (z * z) * _C3)
        r = hi + ((t + lo) + w)
    elif a < 0.0625:
        if a < _TINY:
            return x
        z = x * x
        w = z * z
        return x + x * z * (((_C1 + z * _C2) + w * (_C3 + z * _C4)) + (w * w) * ((_C5 + z * _C6) + w * _C7))
    elif a <= _HUGE:
        y = 64.0 / a
        n = (y + _ROUND) - _ROUND
        hi, lo = _ACOT[n]
        t = (64.0 - a * n) / (a * 64.0 + n)
        z = t * t
        w = t * z * ((_C1 + z * _C2) + (z * z) * _C3)
        r = hi - ((t - lo) + w)
    elif a > _HUGE:
        r = ACOT_K64[0][0]
    else:
        return x + x  # NaN
    return -r if x < 0.0 else r


def atan2(y, x):
    """The angle [rad] of the point (``x``, ``y``), in [-pi, pi]: the floats of the C core's
    ``sm_atan2``, built on :func:`atan` (not the platform's ``math.atan2``).

    The special cases are C99's (Annex F, as ``math.atan2``): ``atan2(+-0, +0 or x > 0) = +-0``,
    ``atan2(+-0, -0 or x < 0) = +-pi``, ``atan2(y, +-0) = +-pi/2`` (y != 0), ``atan2(+-inf, +inf) =
    +-pi/4``, ``atan2(+-inf, -inf) = +-3 pi/4``, ``atan2(+-inf, x) = +-pi/2`` (x finite),
    ``atan2(+-y, +inf) = +-0`` and ``atan2(+-y, -inf) = +-pi`` (y finite), NaN for a NaN.  Otherwise
    ``z = atan(|y| / |x|)``, and ``pi - z`` for ``x < 0`` (as ``pi_hi - (z - pi_lo)``); its error is
    below 0.62 ulp of ``atan`` plus the quotient's 0.5 ulp (``|q atan'(q) / atan(q)| <= 1``) and the
    subtraction's rounding: within 2 ulp of the exact value (``tests/test_atan.py`` measures it)."""
    if x != x or y != y:
        return x + y  # NaN
    ax = x if x >= 0.0 else -x
    ay = y if y >= 0.0 else -y
    if ay == 0.0:  # +-0, its sign kept: +-0 for x = +0 or x > 0, +-pi for x = -0 or x < 0
        if math.copysign(1.0, x) > 0.0:
            return y
        r = _PI
    elif ax == 0.0:
        r = _PI_2
    elif ay == math.inf:
        r = _PI_2 if ax < math.inf else (_PI_4 if x > 0.0 else _PI_3_4)
    elif ax == math.inf:
        r = 0.0 if x > 0.0 else _PI
    else:
        z = atan(ay / ax)
        r = z if x > 0.0 else _PI - (z - _PI_LO)
    return -r if math.copysign(1.0, y) < 0.0 else r
