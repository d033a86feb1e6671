// Decodes messages the way lcm-spy does: finds the class for the message's fingerprint among the jars on
// CLASSPATH (lcm.spy.LCMTypeDatabase), constructs it from the bytes, and prints its public fields.
// Exits after the first message on the channel, or after a timeout.
import java.io.DataInput;
import java.lang.reflect.Array;
import java.lang.reflect.Field;
import java.lang.reflect.Modifier;
import lcm.lcm.LCM;
import lcm.lcm.LCMDataInputStream;
import lcm.lcm.LCMSubscriber;
import lcm.spy.LCMTypeDatabase;

public class SpyDecode implements LCMSubscriber {
  private final LCMTypeDatabase db = new LCMTypeDatabase();
  private volatile boolean done = false;

  public synchronized void messageReceived(LCM lcm, String channel, LCMDataInputStream ins) {
    if (done) return;
    try {
      long fingerprint = ins.readLong();
      Class<?> cls = db.getClassByFingerprint(fingerprint);
      if (cls == null) {
        System.out.println("UNKNOWN fingerprint " + Long.toHexString(fingerprint));
        done = true;
        return;
      }
      ins.reset();
      Object o = cls.getConstructor(DataInput.class).newInstance(ins);
      StringBuilder sb = new StringBuilder(cls.getName());
      for (Field f : cls.getFields()) {
        if (Modifier.isStatic(f.getModifiers())) continue;
        sb.append(' ').append(f.getName()).append('=').append(format(f.get(o)));
      }
      System.out.println(sb);
      done = true;
    } catch (Exception e) {
      System.out.println("DECODE-ERROR " + e);
      done = true;
    }
  }

  private static String format(Object v) {
    if (v == null || !v.getClass().isArray()) return String.valueOf(v);
    StringBuilder sb = new StringBuilder("[");
    for (int i = 0; i < Array.getLength(v); ++i) sb.append(i > 0 ? "," : "").append(format(Array.get(v, i)));
    return sb.append(']').toString();
  }

  public static void main(String[] args) throws Exception {
    String url = args[0], channel = args[1];
    SpyDecode me = new SpyDecode();
    LCM lcm = new LCM(url);
    lcm.subscribe(channel, me);
    System.out.println("ready");
    long end = System.currentTimeMillis() + 20000;
    while (!me.done && System.currentTimeMillis() < end) Thread.sleep(20);
    if (!me.done) System.out.println("TIMEOUT");
    System.exit(0);
  }
}
