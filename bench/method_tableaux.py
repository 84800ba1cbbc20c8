"""Butcher tableaux of the embedded explicit Runge-Kutta (and Runge-Kutta-Nystrom) pairs that
bench/method_study.py compares, with their dense outputs, as numpy arrays.

Every coefficient is copied, not derived, from a well-kept public source (named at each pair); the pairs'
orders (solution, embedded estimate, dense output) are checked numerically by tests/test_method_study.py.

A pair is stored uniformly (stages numbered from 0):

- ``A`` (S, S): stage q is evaluated at y + h sum_j A[q, j] k_j (S counts the dense output's extra stages);
- ``b`` (S,): y_new = y + h sum_q b[q] k_q;
- ``e`` (S,) and optionally ``e2``: error estimates h sum_q e[q] k_q (BS5 takes the larger of its two);
- ``n_step``: stages evaluated in every step (with a FSAL pair its last one is f(y_new));
- ``end_stage``: the stage that is f(y_new) (whose row of A is b), reused as the next step's first stage;
- ``D`` (S, P): dense output y(t + x h) = y + h sum_q b_q(x) k_q, b_q(x) = sum_p D[q, p] x^(p+1);
  it needs the stages up to ``n_dense`` (the extra ones are evaluated only when a step's dense output is used);
- ``error_order``: the order of the error estimate (the step-size exponent is -1 / (error_order + 1),
  as SciPy's RK45 and the FMU use it).

The Runge-Kutta-Nystrom pair (y'' = f(t, y, y')) has position and velocity weights instead (:class:`NystromPair`).
"""
from __future__ import annotations

import re
from fractions import Fraction
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Pair:
    name: str
    order: int
    error_order: int
    A: np.ndarray
    b: np.ndarray
    e: np.ndarray
    n_step: int
    end_stage: int
    D: np.ndarray
    n_dense: int
    dense_order: int
    source: str
    e2: np.ndarray = field(default=None)

    @property
    def c(self) -> np.ndarray:
        return self.A.sum(axis=1)

    @property
    def rhs_per_step(self) -> int:
        """New right-hand sides per accepted step: every stage but the first (f(y), reused when FSAL)."""
        return self.n_step - 1 if self.end_stage < self.n_step else self.n_step

    @property
    def extra_dense_stages(self) -> int:
        return self.n_dense - self.n_step


@dataclass(frozen=True)
class NystromPair:
    """u'' = f(u, u'): U_q = u + c_q h u' + h^2 sum_j a[q, j] K_j, V_q = u' + h sum_j abar[q, j] K_j,
    u_new = u + h u' + h^2 sum b K, u'_new = u' + h sum bp K; errors h^2 sum btilde K, h sum bptilde K.
    The last stage is f(u_new, u'_new) (FSAL). Dense output: quintic Hermite in u (u, u', u'' at both
    ends), its derivative for u'."""
    name: str
    order: int
    error_order: int
    a: np.ndarray
    abar: np.ndarray
    b: np.ndarray
    bp: np.ndarray
    btilde: np.ndarray
    bptilde: np.ndarray
    c_published: np.ndarray
    source: str

    @property
    def c(self) -> np.ndarray:
        return self.abar.sum(axis=1)

    @property
    def n_step(self) -> int:
        return len(self.b)

    @property
    def end_stage(self) -> int:
        return len(self.b) - 1

    @property
    def rhs_per_step(self) -> int:
        return self.n_step - 1

    extra_dense_stages = 0


def _indices(digits: str) -> tuple[int, int]:
    """(row, column), 1-based, of a coefficient named as OrdinaryDiffEq.jl names them: a21, a021, a101,
    a1001, a1110 (and r-coefficients alike: r13, r042, r106)."""
    if len(digits) == 2:
        return int(digits[0]), int(digits[1])
    if len(digits) == 3:
        return (int(digits[1]), int(digits[2])) if digits[0] == "0" else (int(digits[:2]), int(digits[2]))
    if len(digits) == 4:
        return int(digits[:2]), int(digits[2:])
    raise ValueError(f"coefficient index {digits!r}")


def _matrix(values: dict, prefix: str, shape: tuple[int, int]) -> np.ndarray:
    out = np.zeros(shape)
    for key, value in values.items():
        m = re.fullmatch(prefix + r"(\d+)", key)
        if m:
            i, j = _indices(m.group(1))
            out[i - 1, j - 1] = value
    return out


def _vector(values: dict, prefix: str, size: int) -> np.ndarray:
    out = np.zeros(size)
    for key, value in values.items():
        m = re.fullmatch(prefix + r"(\d+)", key)
        if m:
            out[int(m.group(1)) - 1] = value
    return out


# ---------------------------------------------------------------------------------------------------------
# Coefficients as OrdinaryDiffEq.jl tabulates them (Float64 versions; SciML/OrdinaryDiffEq.jl, commit b211787f7:
# lib/OrdinaryDiffEqTsit5/src/tsit_tableaus.jl (Tsit5ConstantCacheActual, Tsit5Interp),
# lib/OrdinaryDiffEqLowOrderRK/src/low_order_rk_tableaus.jl (BS5ConstantCache, BS5Interp, BS5Interp_polyweights),
# lib/OrdinaryDiffEqVerner/src/verner_tableaus.jl (Vern6/Vern7 Tableau, ExtraStages, InterpolationCoefficients)).
# Names as there: aIJ row I column J (1-based), btildeQ the error weights, rQP the dense weight of stage Q at x^P.
_TSIT5 = {
    "c1": 0.161, "c2": 0.327, "c3": 0.9, "c4": 0.9800255409045097, "c5": 1, "c6": 1, "a21": 0.161,
    "a31": -0.008480655492356989, "a32": 0.335480655492357, "a41": 2.8971530571054935, "a42": -6.359448489975075,
    "a43": 4.3622954328695815, "a51": 5.325864828439257, "a52": -11.748883564062828, "a53": 7.4955393428898365,
    "a54": -0.09249506636175525, "a61": 5.86145544294642, "a62": -12.92096931784711, "a63": 8.159367898576159,
    "a64": -0.071584973281401, "a65": -0.028269050394068383, "a71": 0.09646076681806523, "a72": 0.01,
    "a73": 0.4798896504144996, "a74": 1.379008574103742, "a75": -3.290069515436081, "a76": 2.324710524099774,
    "btilde1": -0.00178001105222577714, "btilde2": -0.0008164344596567469, "btilde3": 0.007880878010261995,
    "btilde4": -0.1447110071732629, "btilde5": 0.5823571654525552, "btilde6": -0.45808210592918697,
    "btilde7": 0.015151515151515152,
}

_TSIT5_INTERP = {
    "r11": 1.0, "r12": -2.763706197274826, "r13": 2.9132554618219126, "r14": -1.0530884977290216,
    "r22": 0.13169999999999998, "r23": -0.2234, "r24": 0.1017, "r32": 3.9302962368947516, "r33": -5.941033872131505,
    "r34": 2.490627285651253, "r42": -12.411077166933676, "r43": 30.33818863028232, "r44": -16.548102889244902,
    "r52": 37.50931341651104, "r53": -88.1789048947664, "r54": 47.37952196281928, "r62": -27.896526289197286,
    "r63": 65.09189467479366, "r64": -34.87065786149661, "r72": 1.5, "r73": -4, "r74": 2.5,
}

_BS5 = {
    "c1": 0.16666666666666666, "c2": 0.2222222222222222, "c3": 0.42857142857142855, "c4": 0.6666666666666666,
    "c5": 0.75, "a21": 0.16666666666666666, "a31": 0.07407407407407407, "a32": 0.14814814814814814,
    "a41": 0.13338192419825073, "a42": -0.47230320699708456, "a43": 0.7674927113702624, "a51": 0.22895622895622897,
    "a52": -0.36363636363636365, "a53": 0.2937062937062937, "a54": 0.5076405076405076, "a61": 0.026500355113636364,
    "a62": 0.23011363636363635, "a63": 0.10772747760052448, "a64": 0.1602190777972028, "a65": 0.225439453125,
    "a71": 0.18159821692916506, "a72": -0.38707982536247293, "a73": 0.41288268560074054, "a74": 0.6409913191253497,
    "a75": -1.0121439383514517, "a76": 1.1637515420586695, "a81": 0.07279265873015874, "a83": 0.28662437773692473,
    "a84": 0.19513621794871794, "a85": 0.008638392857142857, "a86": 0.3595655806182122, "a87": 0.07724277210884353,
    "bhat1": -0.00234375, "bhat3": 0.0103760754048583, "bhat4": -0.016490384615384615, "bhat5": 0.018984375,
    "bhat6": -0.010526315789473684, "btilde1": -0.0019478942125547064, "btilde3": 0.009048699186152193,
    "btilde4": -0.015478743126634073, "btilde5": 0.021222718253968254, "btilde6": -0.013276905111429694,
    "btilde7": -0.005480370770138146, "btilde8": 0.005912495780636172,
}

_BS5_EXTRA = {
    "c6": 0.5, "c7": 0.8333333333333334, "c8": 0.1111111111111111, "a91": 0.07405598958333333, "a92": 0,
    "a93": 0.28964485093442743, "a94": 0.12839214966168092, "a95": -0.003779296875, "a96": 0.014230019493177388,
    "a97": -0.03379371279761905, "a98": 0.03125, "a101": -0.06358724036162344, "a102": 0.5742461924818869,
    "a103": -0.06365063007249953, "a104": 0.043159777438314964, "a105": 0.8370112883898733,
    "a106": -0.34045447246719235, "a107": 0.04926503818334922, "a108": -0.006882677669165967,
    "a109": -0.19577394258960973, "a111": 0.0636090772400987, "a112": 0.01057854182854183,
    "a113": 0.06600100945670531, "a114": 0.02048391555358402, "a115": 0.003682270330219549,
    "a116": 0.155258632271002, "a117": -0.08509702513818027, "a118": 0.1, "a119": -0.1,
    "a1110": -0.12340531043086005,
}

_BS5_INTERP = {
    "r016": -11.547607240534195, "r015": 36.89579791207878, "r014": -45.470343197183475, "r013": 27.298136302807084,
    "r012": -8.103191118438032, "r036": -27.245925284262768, "r035": 74.85879078710211, "r034": -72.2759709558427,
    "r033": 28.38602193195626, "r032": -3.4362921012159933, "r046": -14.307769126529058, "r045": 38.240038148817945,
    "r044": -35.469854845413806, "r043": 13.060399314592578, "r042": -1.3276772735189397,
    "r056": -0.7296779223862557, "r055": 1.9817123385873385, "r054": -1.964240395021645, "r053": 0.8847786781120115,
    "r052": -0.16393430643430643, "r066": 19.121088881250603, "r065": -65.9928405785889, "r064": 77.4690381021765,
    "r063": -34.163041154825144, "r062": 3.9253203306051474, "r076": -14.676126700680273, "r075": 42.17455357142857,
    "r074": -42.4062818877551, "r073": 16.83892431972789, "r072": -1.853826530612245, "r086": 19.453125,
    "r085": -54.359375, "r084": 53.671875, "r083": -21.078125, "r082": 2.3125, "r096": 18.333333333333332,
    "r095": -39, "r094": 23, "r093": -2.3333333333333335, "r106": -23.400440940191388, "r105": 70.20132282057416,
    "r104": -73.55422182095978, "r103": 30.106238940962648, "r102": -3.3528990003856314, "r116": 35, "r115": -105,
    "r114": 117, "r113": -59, "r112": 12,
}

_VERN6_EXTRA = {
    "c10": 0.5, "a1001": 0.016524159013572806, "a1004": 0.3053128187514179, "a1005": 0.2071200938201979,
    "a1006": -1.293879140655123, "a1007": 57.11988411588149, "a1008": -55.87979207510932,
    "a1009": 0.024830028297766014, "c11": 0.828, "a1101": 0.038150081818627744, "a1104": 0.2502358252513705,
    "a1105": 0.3249441447817608, "a1106": 1.8224606658327962, "a1107": -67.7137233269262,
    "a1108": 66.03587911808127, "a1109": -0.0363881087495127, "a1110": 0.106441599909888, "c12": 0.28,
    "a1201": 0.11178168039666012, "a1204": 0.025757505109345213, "a1205": 3.785140856363646,
    "a1206": 92.34088993695727, "a1207": -3819.461508432344, "a1208": 3732.492711530704,
    "a1209": -1.0756940209963033, "a1210": -3.231539970732086, "a1211": -4.707539085458635,
}

_VERN6_INTERP = {
    "r011": 1, "r012": -7.778593856495576, "r013": 27.0524385722671, "r014": -45.780190114576975,
    "r015": 36.723777410436384, "r016": -11.183042432947357, "r042": 16.632102138279762, "r043": -86.25583404770623,
    "r044": 171.73305461826962, "r045": -149.67744091315947, "r046": 47.826380659879696, "r052": 27.10835046149758,
    "r053": -140.58676162962996, "r054": 279.90447579689163, "r055": -243.95644583707966, "r056": 77.95131832728772,
    "r062": 283.70753264670356, "r063": -1471.3371557366656, "r064": 2929.3928569314394, "r065": -2553.17199842168,
    "r066": 815.8141610498723, "r072": -11365.512865164834, "r073": 58942.74718938947, "r074": -117353.43045697975,
    "r075": 102281.77209230464, "r076": -32682.059078573824, "r082": 11100.250191051131,
    "r083": -57567.067013355576, "r084": 114614.48808378985, "r085": -99894.591091309, "r086": 31919.283963225014,
    "r092": -3.0022825150732126, "r093": 14.946122435958785, "r094": -27.826954732510288,
    "r095": 21.824672217437076, "r096": -5.941557405812358, "r102": -19.610347376201034, "r103": 93.13370014508226,
    "r104": -165.3493635542416, "r105": 129.73901617804057, "r106": -37.91300539268019, "r112": -18.23029074639409,
    "r113": 96.74593449012313, "r114": -199.08634973839895, "r115": 180.85605899200485, "r116": -60.285352997334954,
    "r122": -13.563796638614157, "r123": 90.62137973668116, "r124": -204.04515601697273, "r125": 190.48135937835858,
    "r126": -63.493786459452856,
}

_VERN6 = {
    "c1": 0.06, "c2": 0.09593333333333333, "c3": 0.1439, "c4": 0.4973, "c5": 0.9725, "c6": 0.9995, "a21": 0.06,
    "a31": 0.019239962962962962, "a32": 0.07669337037037037, "a41": 0.035975, "a43": 0.107925,
    "a51": 1.3186834152331484, "a53": -5.042058063628562, "a54": 4.220674648395414, "a61": -41.87259166432751,
    "a63": 159.43256216313748, "a64": -122.11921356501004, "a65": 5.531743066200053, "a71": -54.430156935316504,
    "a73": 207.06725136501848, "a74": -158.61081378459, "a75": 6.991816585950242, "a76": -0.01859723106220323,
    "a81": -54.66374178728198, "a83": 207.95280625538936, "a84": -159.2889574744995, "a85": 7.018743740796944,
    "a86": -0.018338785905045722, "a87": -0.0005119484997882099, "a91": 0.03438957868357036,
    "a94": 0.25826245556335037, "a95": 0.4209371189673537, "a96": 4.40539646966931, "a97": -176.48311902429865,
    "a98": 172.36413340141507, "btilde1": 0.008623404282200854, "btilde4": -0.019434029953152708,
    "btilde5": 0.028450072588037983, "btilde6": -2.1097110610652914, "btilde7": 103.45854289996397,
    "btilde8": -101.39980461914912, "btilde9": 0.03333333333333333,
}

_VERN7_EXTRA = {
    "c11": 1, "a1101": 0.04715561848627222, "a1104": 0.25750564298434153, "a1105": 0.2621665397741262,
    "a1106": 0.15216092656738558, "a1107": 0.49399691700324844, "a1108": -0.29430311714032503,
    "a1109": 0.0813174723249511, "c12": 0.29, "a1201": 0.0523222769159969, "a1204": 0.22495861826705715,
    "a1205": 0.017443709248776376, "a1206": -0.007669379876829393, "a1207": 0.03435896044073285,
    "a1208": -0.0410209723009395, "a1209": 0.025651133005205617, "a1211": -0.0160443457, "c13": 0.125,
    "a1301": 0.053053341257859085, "a1304": 0.12195301011401886, "a1305": 0.017746840737602496,
    "a1306": -0.0005928372667681495, "a1307": 0.008381833970853752, "a1308": -0.01293369259698612,
    "a1309": 0.009412056815253861, "a1311": -0.005353253107275676, "a1312": -0.06666729992455811, "c14": 0.25,
    "a1401": 0.03887903257436304, "a1404": -0.0024403203308301317, "a1405": -0.0013928917214672623,
    "a1406": -0.00047446291558680135, "a1407": 0.00039207932413159514, "a1408": -0.00040554733285128004,
    "a1409": 0.00019897093147716726, "a1411": -0.00010278198793179169, "a1412": 0.03385661513870267,
    "a1413": 0.1814893063199928, "c15": 0.53, "a1501": 0.05723681204690013, "a1504": 0.22265948066761182,
    "a1505": 0.12344864200186899, "a1506": 0.04006332526666491, "a1507": -0.05269894848581452,
    "a1508": 0.04765971214244523, "a1509": -0.02138895885042213, "a1511": 0.015193891064036402,
    "a1512": 0.12060546716289655, "a1513": -0.022779423016187374, "c16": 0.79, "a1601": 0.051372038802756814,
    "a1604": 0.5414214473439406, "a1605": 0.350399806692184, "a1606": 0.14193112269692182,
    "a1607": 0.10527377478429423, "a1608": -0.031081847805874016, "a1609": -0.007401883149519145,
    "a1611": -0.006377932504865363, "a1612": -0.17325495908361865, "a1613": -0.18228156777622026,
}

_VERN7_INTERP = {
    "r011": 1, "r012": -8.413387198332767, "r013": 33.675508884490895, "r014": -70.80159089484886,
    "r015": 80.64695108301298, "r016": -47.19413969837522, "r017": 11.133813442539243, "r042": 8.754921980674396,
    "r043": -88.4596828699771, "r044": 346.9017638429916, "r045": -629.2580030059837, "r046": 529.6773755604193,
    "r047": -167.35886986514018, "r052": 8.913387586637922, "r053": -90.06081846893218, "r054": 353.1807459217058,
    "r055": -640.6476819744374, "r056": 539.2646279047156, "r057": -170.38809442991547, "r062": 5.1733120298478,
    "r063": -52.271115900055385, "r064": 204.9853867374073, "r065": -371.8306118563603, "r066": 312.9880934374529,
    "r067": -98.89290352172495, "r072": 16.79537744079696, "r073": -169.70040000059728, "r074": 665.4937727009246,
    "r075": -1207.1638892336007, "r076": 1016.1291515818546, "r077": -321.06001557237494,
    "r082": -10.005997536098665, "r083": 101.1005433052275, "r084": -396.47391512378437, "r085": 719.1787707014183,
    "r086": -605.3681033918824, "r087": 191.27439892797935, "r092": 2.764708833638599, "r093": -27.934602637390462,
    "r094": 109.54779186137893, "r095": -198.7128113064482, "r096": 167.26633571640318, "r097": -52.85010499525706,
    "r112": -2.1696320280163506, "r113": 22.016696037569876, "r114": -86.90152427798948, "r115": 159.22388973861476,
    "r116": -135.9618306534588, "r117": 43.792401183280006, "r122": -4.890070188793804, "r123": 22.75407737425176,
    "r124": -30.78034218537731, "r125": -2.797194317207249, "r126": 31.369456637508403, "r127": -15.655927320381801,
    "r132": 10.862170929551967, "r133": -50.542971417827104, "r134": 68.37148040407511, "r135": 6.213326521632409,
    "r136": -69.68006323194157, "r137": 34.776056794509195, "r142": -11.37286691922923, "r143": 130.79058078246717,
    "r144": -488.65113677785604, "r145": 832.2148793276441, "r146": -664.7743368554426, "r147": 201.79288044241662,
    "r152": -5.919778732715007, "r153": 63.27679965889219, "r154": -265.432682088738, "r155": 520.1009254140611,
    "r156": -467.412109533902, "r157": 155.3868452824017, "r162": -10.492146197961823, "r163": 105.35538525188011,
    "r164": -409.43975011988937, "r165": 732.831448907654, "r166": -606.3044574733512, "r167": 188.0495196316683,
}

_VERN7 = {
    "c2": 0.005, "c3": 0.10888888888888888, "c4": 0.16333333333333333, "c5": 0.4555, "c6": 0.6095094489978381,
    "c7": 0.884, "c8": 0.925, "a021": 0.005, "a031": -1.07679012345679, "a032": 1.185679012345679,
    "a041": 0.04083333333333333, "a043": 0.1225, "a051": 0.6389139236255726, "a053": -2.455672638223657,
    "a054": 2.272258714598084, "a061": -2.6615773750187572, "a063": 10.804513886456137, "a064": -8.3539146573962,
    "a065": 0.820487594956657, "a071": 6.067741434696772, "a073": -24.711273635911088, "a074": 20.427517930788895,
    "a075": -1.9061579788166472, "a076": 1.006172249242068, "a081": 12.054670076253203, "a083": -49.75478495046899,
    "a084": 41.142888638604674, "a085": -4.461760149974004, "a086": 2.042334822239175, "a087": -0.09834843665406107,
    "a091": 10.138146522881808, "a093": -42.6411360317175, "a094": 35.76384003992257, "a095": -4.3480228403929075,
    "a096": 2.0098622683770357, "a097": 0.3487490460338272, "a098": -0.27143900510483127,
    "a101": -45.030072034298676, "a103": 187.3272437654589, "a104": -154.02882369350186, "a105": 18.56465306347536,
    "a106": -7.141809679295079, "a107": 1.3088085781613787, "b1": 0.04715561848627222, "b4": 0.25750564298434153,
    "b5": 0.26216653977412624, "b6": 0.15216092656738558, "b7": 0.4939969170032485, "b8": -0.29430311714032503,
    "b9": 0.08131747232495111, "btilde1": 0.002547011879931045, "btilde4": -0.00965839487279575,
    "btilde5": 0.04206470975639691, "btilde6": -0.0666822437469301, "btilde7": 0.2650097464621281,
    "btilde8": -0.29430311714032503, "btilde9": 0.08131747232495111, "btilde10": -0.02029518466335628,
}


# Fine's general Runge-Kutta-Nystrom 5(4) pair (J. M. Fine, Low order practical Runge-Kutta-Nystrom methods,
# Computing 38 (1987) 281-297), for u'' = f(t, u, u'), exact rationals as OrdinaryDiffEq.jl tabulates it
# (lib/OrdinaryDiffEqRKN/src/rkn_tableaus.jl, FineRKN5Tableau; aIJ and abarIJ 1-based).
_FINE_RKN5_A = {
    (2, 1): Fraction(32, 1521),
    (3, 1): Fraction(4, 169),
    (3, 2): Fraction(4, 169),
    (4, 1): Fraction(175, 5184),
    (4, 3): Fraction(1625, 5184),
    (5, 1): Fraction(-342497279, 5618900760),
    (5, 2): Fraction(6827067, 46824173),
    (5, 3): Fraction(35048741, 102161832),
    (5, 4): Fraction(-2201514, 234120865),
    (6, 1): Fraction(-7079, 52152),
    (6, 2): Fraction(767, 2173),
    (6, 3): Fraction(14027, 52152),
    (6, 4): Fraction(30, 2173),
    (7, 1): Fraction(4817, 51600),
    (7, 3): Fraction(388869, 1216880),
    (7, 4): Fraction(3276, 23575),
    (7, 5): Fraction(-1142053, 22015140),
}
_FINE_RKN5_ABAR = {
    (2, 1): Fraction(8, 39),
    (3, 1): Fraction(1, 13),
    (3, 2): Fraction(3, 13),
    (4, 1): Fraction(7385, 6912),
    (4, 2): Fraction(-9425, 2304),
    (4, 3): Fraction(13325, 3456),
    (5, 1): Fraction(223324757, 91364240),
    (5, 2): Fraction(-174255393, 18272848),
    (5, 3): Fraction(382840094, 46824173),
    (5, 4): Fraction(-39627252, 234120865),
    (6, 1): Fraction(108475, 36464),
    (6, 2): Fraction(-9633, 848),
    (6, 3): Fraction(7624604, 806183),
    (6, 4): Fraction(8100, 49979),
    (6, 5): Fraction(-4568212, 19446707),
    (7, 1): Fraction(4817, 51600),
    (7, 3): Fraction(1685099, 3650640),
    (7, 4): Fraction(19656, 23575),
    (7, 5): Fraction(-53676491, 88060560),
    (7, 6): Fraction(53, 240),
}
_FINE_RKN5_B = [
    Fraction(4817, 51600),
    0,
    Fraction(388869, 1216880),
    Fraction(3276, 23575),
    Fraction(-1142053, 22015140),
    0,
    0,
]
_FINE_RKN5_BP = [
    Fraction(4817, 51600),
    0,
    Fraction(1685099, 3650640),
    Fraction(19656, 23575),
    Fraction(-53676491, 88060560),
    Fraction(53, 240),
    0,
]
_FINE_RKN5_BTILDE = [
    Fraction(8151, 2633750),
    0,
    Fraction(-1377519, 186334750),
    Fraction(586872, 28879375),
    Fraction(-36011118, 2247378875),
    0,
    0,
]
_FINE_RKN5_BPTILDE = [
    Fraction(8151, 2633750),
    0,
    Fraction(-5969249, 559004250),
    Fraction(3521232, 28879375),
    Fraction(-846261273, 4494757750),
    Fraction(4187, 36750),
    Fraction(-1, 25),
]
_FINE_RKN5_C = [Fraction(8, 39), Fraction(4, 13), Fraction(5, 6), Fraction(43, 47), 1, 1]


# ---------------------------------------------------------------------------------------------------------
def _dense(values: dict, stages: int) -> np.ndarray:
    powers = max(_indices(m.group(1))[1] for m in (re.fullmatch(r"r(\d+)", k) for k in values) if m)
    return _matrix(values, "r", (stages, powers))


def tsit5() -> Pair:
    A = _matrix(_TSIT5, "a", (7, 7))
    D = _dense(_TSIT5_INTERP, 7)
    return Pair("Tsit5", 5, 4, A, A[6].copy(), _vector(_TSIT5, "btilde", 7), 7, 6, D, 7, 4,
                "Ch. Tsitouras, Comput. Math. Appl. 62 (2011) 770-775; coefficients and interpolant as "
                "OrdinaryDiffEq.jl's tsit_tableaus.jl")


def _scipy_pair(name: str, solver, order: int, dense_order: int, source: str) -> Pair:
    s = solver.n_stages
    A = np.zeros((s + 1, s + 1))
    A[:s, :solver.A.shape[1]] = solver.A
    A[s, :s] = solver.B
    return Pair(name, order, solver.error_estimator_order, A, A[s].copy(), np.array(solver.E, dtype=float),
                s + 1, s, np.array(solver.P, dtype=float), s + 1, dense_order, source)


def dopri5() -> Pair:
    from scipy.integrate._ivp.rk import RK45

    return _scipy_pair("DP5", RK45, 5, 4, "J. R. Dormand, P. J. Prince, J. Comput. Appl. Math. 6 (1980) 19-26, "
                       "with Shampine's dense output; as scipy.integrate.RK45 tabulates it (A, B, E, P)")


def bs3() -> Pair:
    from scipy.integrate._ivp.rk import RK23

    return _scipy_pair("BS3", RK23, 3, 3, "P. Bogacki, L. F. Shampine, Appl. Math. Lett. 2 (1989) 321-325; as "
                       "scipy.integrate.RK23 tabulates it (A, B, E, P: cubic Hermite dense output)")


def bs5() -> Pair:
    values = {**_BS5, **_BS5_EXTRA}
    A = _matrix(values, "a", (11, 11))
    D = _dense(_BS5_INTERP, 11)
    D[0, 0] += 1.0  # OrdinaryDiffEq adds dt * x * k1 apart: b_1(x) = x + r012 x^2 + ...
    return Pair("BS5", 5, 4, A, A[7].copy(), _vector(_BS5, "btilde", 11), 8, 7, D, 11, 5,
                "P. Bogacki, L. F. Shampine, Comput. Math. Appl. 32 (1996) 15-28 (with its two error estimates, "
                "the larger taken, and the 3 lazy stages of its 5th-order interpolant, from RKSuite); as "
                "OrdinaryDiffEq.jl's low_order_rk_tableaus.jl", _vector(_BS5, "bhat", 11))


def vern6() -> Pair:
    A = _matrix({**_VERN6, **_VERN6_EXTRA}, "a", (12, 12))
    D = _dense(_VERN6_INTERP, 12)
    return Pair("Vern6", 6, 5, A, A[8].copy(), _vector(_VERN6, "btilde", 12), 9, 8, D, 12, 6,
                "J. H. Verner's 'most efficient' 6(5) pair (Numer. Algorithms 53 (2010) 383-396, and his "
                "website's interpolants: 3 extra stages for order 6); as OrdinaryDiffEq.jl's verner_tableaus.jl")


def vern7() -> Pair:
    A = _matrix({**_VERN7, **_VERN7_EXTRA}, "a", (16, 16))
    D = _dense(_VERN7_INTERP, 16)
    return Pair("Vern7", 7, 6, A, _vector(_VERN7, "b", 16), _vector(_VERN7, "btilde", 16), 10, 10, D, 16, 7,
                "J. H. Verner's 'most efficient' 7(6) pair (Numer. Algorithms 53 (2010) 383-396, and his "
                "website's interpolants: f(y_new) and 5 extra stages for order 7); as OrdinaryDiffEq.jl's "
                "verner_tableaus.jl")


def fine_rkn5() -> NystromPair:
    def matrix(entries):
        out = np.zeros((7, 7))
        for (i, j), value in entries.items():
            out[i - 1, j - 1] = float(value)
        return out

    def vector(values):
        return np.array([float(v) for v in values])

    return NystromPair("FineRKN5", 5, 4, matrix(_FINE_RKN5_A), matrix(_FINE_RKN5_ABAR), vector(_FINE_RKN5_B),
                       vector(_FINE_RKN5_BP), vector(_FINE_RKN5_BTILDE), vector(_FINE_RKN5_BPTILDE),
                       np.concatenate([[0.0], vector(_FINE_RKN5_C)]),
                       "J. M. Fine, Computing 38 (1987) 281-297 (general RKN 5(4), velocity-dependent f); as "
                       "OrdinaryDiffEq.jl's rkn_tableaus.jl (FineRKN5Tableau)")


PAIRS = {"tsit5": tsit5, "dp5": dopri5, "bs3": bs3, "bs5": bs5, "vern6": vern6, "vern7": vern7, "fine_rkn5": fine_rkn5}
