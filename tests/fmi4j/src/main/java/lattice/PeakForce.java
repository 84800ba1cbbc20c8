package lattice;

import java.io.File;
import java.util.Locale;

import no.ntnu.ihb.fmi4j.FmiStatus;
import no.ntnu.ihb.fmi4j.importer.fmi2.CoSimulationSlave;
import no.ntnu.ihb.fmi4j.importer.fmi2.Fmu;
import no.ntnu.ihb.fmi4j.modeldescription.variables.ModelVariables;

/**
 * Co-simulates the lattice FMU in FMI4j and prints peak_backplate_force for each material order.
 *
 * <pre>java -cp CLASSES:DEPENDENCIES/* lattice.PeakForce FMU STOP_TIME STEP ORDER [ORDER ...]</pre>
 *
 * An ORDER is a comma-separated permutation such as 1,7,5,9,3,6,11,8,2,4,10. Each printed line is
 * {@code peak ORDER VALUE} with VALUE in Java's shortest round-trip form, so no digit is lost.
 * Exit status 1 (and a message on stderr) when any FMI call fails.
 */
public final class PeakForce {

    private PeakForce() {
    }

    public static void main(String[] args) throws Exception {
        if (args.length < 4) {
            System.err.println("usage: PeakForce FMU STOP_TIME STEP ORDER [ORDER ...]");
            System.exit(2);
        }
        File file = new File(args[0]);
        double stop = Double.parseDouble(args[1]);
        double step = Double.parseDouble(args[2]);
        long steps = Math.round(stop / step);
        try (Fmu fmu = Fmu.from(file)) {
            for (int a = 3; a < args.length; a++) {
                String[] parts = args[a].split(",");
                int[] order = new int[parts.length];
                for (int j = 0; j < parts.length; j++) {
                    order[j] = Integer.parseInt(parts[j].trim());
                }
                double peak = run(fmu, order, stop, step, steps);
                System.out.println("peak " + args[a] + " " + Double.toString(peak));
            }
        }
    }

    private static double run(Fmu fmu, int[] order, double stop, double step, long steps) {
        CoSimulationSlave slave = fmu.asCoSimulationFmu().newInstance();
        try {
            ModelVariables variables = slave.getModelVariables();
            long[] material = new long[order.length];
            for (int j = 0; j < order.length; j++) {
                material[j] = variables.getValueReference("material[" + (j + 1) + "]");
            }
            long[] peak = {variables.getValueReference("peak_backplate_force")};
            check(slave.setupExperiment(0.0, stop, 0.0), slave, "setupExperiment");
            check(slave.enterInitializationMode(), slave, "enterInitializationMode");
            check(slave.writeInteger(material, order) == FmiStatus.OK, slave, "writeInteger(material)");
            check(slave.exitInitializationMode(), slave, "exitInitializationMode");
            for (long i = 0; i < steps; i++) {
                check(slave.doStep(i * step, step), slave, String.format(Locale.ROOT, "doStep at t = %.4f", i * step));
            }
            double[] value = new double[1];
            check(slave.readReal(peak, value) == FmiStatus.OK, slave, "readReal(peak_backplate_force)");
            slave.terminate();
            return value[0];
        } finally {
            slave.close();
        }
    }

    private static void check(boolean ok, CoSimulationSlave slave, String call) {
        if (!ok) {
            System.err.println("FMI4j: " + call + " failed with status " + slave.getLastStatus());
            System.exit(1);
        }
    }
}
