!> Fourth-order Runge-Kutta integration of the state together with its
!> sensitivities dx/dtheta (report eq. 4.35 with zero gain).
!>
!> The input is linear between the samples: u(k) at the start of a step,
!> (u(k)+u(k+1))/2 at the two mid-step stages, u(k+1) at the end (or u(k)
!> throughout with a zero-order hold, chosen by the caller).
module mlid_rk
  use mlid_kinds, only: wp
  use mlid_models, only: model_t, NZ_HROWS
  implicit none
  private
  public :: rk4_step, rk4_interval, input_sens_t, rk_work_t, rk_work_size, small_product
  public :: product_7x4_add, product_7x4_add_tail, past_states

  !> How delayed inputs move the sensitivities: entry k, d u(input(k)) /
  !> d theta(col(k)) at the interval's ends (d0, d1; a tie's scale in it),
  !> linear between them like the inputs.  Forces column col(k) through
  !> df/du(:, input(k)).
  type :: input_sens_t
    integer, allocatable :: input(:), col(:)
    real(wp), allocatable :: d0(:), d1(:)
  end type input_sens_t

  !> The stages' work arrays, kept by the caller from one step to the next:
  !> sized at the first step (and when a size changes), not allocated at
  !> every step.  k: the stage derivatives; sd: the sensitivities' (nx, ns,
  !> 4); xs, ss: a stage's state and sensitivities; a, b, bu: df/dx,
  !> df/dp(idx), df/du; um: the inputs in a step's middle; ua, ub: at its
  !> ends (rk4_interval's, which rk4_step only reads).  first_known: the
  !> caller has already put the first stage's f in k(:, 1) (and, when the
  !> sensitivities are integrated, df/dx and df/dp in a and b) at the
  !> point the next step starts from (the outputs of a sample evaluate the
  !> model there anyway); the next step uses them and clears it.
  !> frow: the row of each column of b that can be nonzero (0: any), the
  !> model's param_rows for its parameters idxm as rk_work_size was told
  !> them (the steps that follow must be given the same idxm), for the
  !> forcing to add those entries alone (add_forcing).  All 0 (dense)
  !> unless told.
  type :: rk_work_t
    real(wp), allocatable :: k(:, :), sd(:, :, :), xs(:), ss(:, :), a(:, :), b(:, :), bu(:, :)
    real(wp), allocatable :: um(:), ua(:), ub(:)
    logical :: first_known = .false.
    integer, allocatable :: frow(:)
  end type rk_work_t

contains

  !> Size wk's stage arrays for nx states, ns sensitivity columns, nb model
  !> parameters forcing them, nu inputs and nv input values (inputs and
  !> noise); kept when they have the size already.  Given the model m and
  !> its nb parameters idxm, the forcing's structure too (rk_work_t's frow):
  !> asked once here, where the caller sets up an integration, not at every
  !> step; arrays sized anew without them forget it.
  subroutine rk_work_size(wk, nx, ns, nb, nu, nv, m, idxm)
    type(rk_work_t), intent(inout) :: wk
    integer, intent(in) :: nx, ns, nb, nu, nv
    class(model_t), intent(in), optional :: m
    integer, intent(in), optional :: idxm(nb)
    if (present(m) .and. present(idxm)) call forcing_rows(m, idxm, wk)   ! (given together)
    if (allocated(wk%sd)) then       ! (one size at a time: no shape arrays at every step)
      if (size(wk%sd, 1) == nx .and. size(wk%sd, 2) == ns .and. size(wk%b, 2) == nb .and. &
          size(wk%bu, 2) == nu .and. size(wk%um) == nv) return
      deallocate (wk%k, wk%sd, wk%xs, wk%ss, wk%a, wk%b, wk%bu, wk%um)
    end if
    if (.not. present(m)) then        ! not told: dense
      if (allocated(wk%frow)) deallocate (wk%frow)
      allocate (wk%frow(nb), source=0)
    end if
    wk%first_known = .false.
    allocate (wk%k(nx, 4), wk%sd(nx, ns, 4), wk%xs(nx), wk%ss(nx, ns), wk%a(nx, nx), &
              wk%b(nx, nb), wk%bu(nx, nu), wk%um(nv))
  end subroutine rk_work_size

  !> wk%frow for the model parameters idxm of m (rk_work_t);
  !> apart from rk_work_size, which every step calls: its d's rows would be
  !> an array allocated at every step.
  subroutine forcing_rows(m, idxm, wk)
    class(model_t), intent(in) :: m
    integer, intent(in) :: idxm(:)
    type(rk_work_t), intent(inout) :: wk
    integer :: hrow(NZ_HROWS, size(idxm))
    if (allocated(wk%frow)) deallocate (wk%frow)
    allocate (wk%frow(size(idxm)))
    call m%param_rows(idxm, wk%frow, hrow)
  end subroutine forcing_rows

  !> Advance x (and s, if given) from t0 to t0+dt.
  !>
  !> s(nx, nf) holds dx/dtheta for the free parameters.  The model
  !> parameters p(idxm(k)) force column colm(k) of the sensitivity equation
  !> through df/dp (several may share a column: ties); the other columns
  !> only propagate through df/dx, plus sforce, a constant forcing of every
  !> column (the filter's held noise estimate).  ua, ub may carry the noise
  !> inputs after the control inputs.  wk: the caller's work arrays.
  subroutine rk4_step(m, p, t0, dt, ua, ub, x, idxm, colm, wcol, wk, s, sforce, us, uf)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), t0, dt, ua(:), ub(:)
    real(wp), intent(inout) :: x(:)
    integer, intent(in) :: idxm(:), colm(:)
    real(wp), intent(in) :: wcol(:)            !< weight of each (1, or a tie's scale)
    type(rk_work_t), intent(inout) :: wk
    real(wp), intent(inout), optional :: s(:, :)
    real(wp), intent(in), optional :: sforce(:, :)
    type(input_sens_t), intent(in), optional :: us   !< delayed inputs over the sample interval
    real(wp), intent(in), optional :: uf(2)   !< where the step starts and ends in it (0..1)
    real(wp) :: th
    integer :: ns, nx

    nx = size(x)
    ns = 0
    if (present(s)) ns = size(s, 2)
    call rk_work_size(wk, size(x), ns, size(idxm), m%nu, size(ua))
    th = t0 + 0.5_wp*dt
    wk%um = 0.5_wp*(ua + ub)
    associate (k => wk%k, xs => wk%xs)
      if (present(s)) then
        call step_sens(s)
      else
        if (.not. wk%first_known) call m%f(t0, x, ua, p, k(:, 1))
        call stage_point(nx, x, 0.5_wp*dt, k(:, 1), xs)
        call m%f(th, xs, wk%um, p, k(:, 2))
        call stage_point(nx, x, 0.5_wp*dt, k(:, 2), xs)
        call m%f(th, xs, wk%um, p, k(:, 3))
        call stage_point(nx, x, dt, k(:, 3), xs)
        call m%f(t0 + dt, xs, ub, p, k(:, 4))
      end if
      call rk4_combine(nx, dt/6.0_wp, k(:, 1), k(:, 2), k(:, 3), k(:, 4), x)
    end associate
    wk%first_known = .false.

  contains

    !> The stages with the sensitivities.
    subroutine step_sens(s)
      real(wp), intent(inout) :: s(:, :)
      associate (k => wk%k, sd => wk%sd, xs => wk%xs, ss => wk%ss)
        call deriv(t0, x, ua, k(:, 1), s, sd(:, :, 1), 0.0_wp)
        call stage_point(nx, x, 0.5_wp*dt, k(:, 1), xs)
        call stage_point(size(s), s, 0.5_wp*dt, sd(:, :, 1), ss)
        call deriv(th, xs, wk%um, k(:, 2), ss, sd(:, :, 2), 0.5_wp)
        call stage_point(nx, x, 0.5_wp*dt, k(:, 2), xs)
        call stage_point(size(s), s, 0.5_wp*dt, sd(:, :, 2), ss)
        call deriv(th, xs, wk%um, k(:, 3), ss, sd(:, :, 3), 0.5_wp)
        call stage_point(nx, x, dt, k(:, 3), xs)
        call stage_point(size(s), s, dt, sd(:, :, 3), ss)
        call deriv(t0 + dt, xs, ub, k(:, 4), ss, sd(:, :, 4), 1.0_wp)
        call rk4_combine(size(s), dt/6.0_wp, sd(:, :, 1), sd(:, :, 2), sd(:, :, 3), sd(:, :, 4), s)
      end associate
    end subroutine step_sens

    !> xd = f, sd = (df/dx) s + wcol df/dp(idxm) (into columns colm) + sforce
    !> + the delayed inputs' forcing at fraction c of the step (at c = 0,
    !> f, df/dx and df/dp may be known already: wk%first_known).
    subroutine deriv(t, xs, ui, xd, ss, sd, c)
      real(wp), intent(in) :: t, xs(nx), ui(:), c
      real(wp), intent(in) :: ss(nx, ns)           ! explicit shapes: contiguous sections
      real(wp), intent(inout) :: xd(nx)            ! pass without descriptors
      real(wp), intent(out) :: sd(nx, ns)

      if (.not. (c == 0.0_wp .and. wk%first_known)) &
        call m%eval(t, xs, ui, p, idxm, xdot=xd, a=wk%a, b=wk%b)
      if (size(xs) == 4) then       ! four states: the fixed-size kernel, no dispatch
        call product_4x4(size(ss, 2), wk%a, ss, sd)
      else
        call small_product(wk%a, ss, sd)
      end if
      if (nx == 4) then             ! (a literal: the compiler's clone for four states)
        call add_forcing(4, ns, size(idxm), wk%b, colm, wcol, wk%frow, sd)
      else
        call add_forcing(nx, ns, size(idxm), wk%b, colm, wcol, wk%frow, sd)
      end if
      if (present(sforce)) sd = sd + sforce
      if (present(us)) call input_forcing(t, xs, ui, c, sd)
    end subroutine deriv

    subroutine input_forcing(t, xs, ui, c, sd)
      real(wp), intent(in) :: t, xs(:), ui(:), c
      real(wp), intent(inout) :: sd(:, :)
      real(wp) :: a
      integer :: k
      if (size(us%input) == 0) return
      call m%dfdu(t, xs, ui, p, wk%bu)
      a = uf(1) + c*(uf(2) - uf(1))         ! the stage's place in the sample interval
      do k = 1, size(us%input)
        sd(:, us%col(k)) = sd(:, us%col(k)) + wk%bu(:, us%input(k))* &
                           ((1.0_wp - a)*us%d0(k) + a*us%d1(k))
      end do
    end subroutine input_forcing

  end subroutine rk4_step

  !> Integrate over the sample interval [t0, t1] in nsub RK4 steps: the
  !> control inputs linear from u0 to u1 (or held at u0 when hold), the
  !> noise inputs w held throughout.  Arguments after x as in rk4_step.
  subroutine rk4_interval(m, p, t0, t1, u0, u1, w, hold, nsub, x, idxm, colm, wcol, wk, s, &
                          sforce, us)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: p(:), t0, t1, u0(:), u1(:), w(:)
    logical, intent(in) :: hold
    integer, intent(in) :: nsub
    real(wp), intent(inout) :: x(:)
    integer, intent(in) :: idxm(:), colm(:)
    real(wp), intent(in) :: wcol(:)
    type(rk_work_t), intent(inout) :: wk
    real(wp), intent(inout), optional :: s(:, :)
    real(wp), intent(in), optional :: sforce(:, :)
    type(input_sens_t), intent(in), optional :: us   !< delayed inputs, at t0 and t1
    real(wp) :: h, ts, uf(2)
    integer :: isub, nu

    if (size(x) == 0) return         ! no states (a regression): nothing to integrate
    nu = size(u0)
    if (allocated(wk%ua)) then
      if (size(wk%ua) /= nu + size(w)) deallocate (wk%ua, wk%ub)
    end if
    if (.not. allocated(wk%ua)) allocate (wk%ua(nu + size(w)), wk%ub(nu + size(w)))
    associate (ua => wk%ua, ub => wk%ub)
      ua(nu + 1:) = w
      ub(nu + 1:) = w
      h = (t1 - t0)/nsub
      do isub = 1, nsub
        ts = t0 + (isub - 1)*h
        if (hold) then
          ua(1:nu) = u0
          ub(1:nu) = u0
        else
          ua(1:nu) = u0 + (u1 - u0)*(real(isub - 1, wp)/nsub)
          ub(1:nu) = u0 + (u1 - u0)*(real(isub, wp)/nsub)
        end if
        if (present(us)) then          ! the delayed inputs' sensitivities, held or linear
          uf = merge([0.0_wp, 0.0_wp], [real(isub - 1, wp), real(isub, wp)]/nsub, hold)
          call rk4_step(m, p, ts, h, ua, ub, x, idxm, colm, wcol, wk, s, sforce, us, uf)
        else if (present(s)) then
          call rk4_step(m, p, ts, h, ua, ub, x, idxm, colm, wcol, wk, s, sforce)
        else
          call rk4_step(m, p, ts, h, ua, ub, x, idxm, colm, wcol, wk)
        end if
      end do
    end associate
  end subroutine rk4_interval

  !> sd(:, col(k)) += w(k) b(:, k): the model parameters' forcing of their
  !> sensitivity columns (explicit shapes: unit strides), where b(:, k) is
  !> zero outside row row(k) that entry alone (row(k) = 0: any row;
  !> model_t%param_rows).  Each entry of sd gets the same nonzero terms in
  !> the same order (a tie's several parameters in one column included), so
  !> the sums are the dense ones to the bit: the terms left out are w(k)*0,
  !> and s + 0 = s.  Only the sign of a zero can differ (-0 + 0 is +0),
  !> which nothing downstream sees: sd is only ever added to the
  !> sensitivities, which start at +0, and a sum with a +0 or nonzero term
  !> is never -0.  nx by value: a literal 4 at the call gets a clone with the
  !> columns' size known (two vector multiply-adds a dense column).
  pure subroutine add_forcing(nx, ns, nb, b, col, w, row, sd)
    integer, value, intent(in) :: nx
    integer, intent(in) :: ns, nb, col(nb), row(nb)
    real(wp), intent(in) :: b(nx, nb), w(nb)
    real(wp), intent(inout) :: sd(nx, ns)
    integer :: k, i
    do k = 1, nb
      i = row(k)
      if (i > 0) then
        sd(i, col(k)) = sd(i, col(k)) + w(k)*b(i, k)
      else
        sd(:, col(k)) = sd(:, col(k)) + w(k)*b(:, k)
      end if
    end do
  end subroutine add_forcing

  !> y = x + h d over n values: a stage's point (the arrays as vectors of
  !> explicit size, so that the loop runs on unit strides).
  pure subroutine stage_point(n, x, h, d, y)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(n), h, d(n)
    real(wp), intent(out) :: y(n)
    y = x + h*d
  end subroutine stage_point

  !> x = x + h6 (d1 + 2 (d2 + d3) + d4) over n values: RK4's step from its
  !> stages' derivatives, h6 = dt/6.
  pure subroutine rk4_combine(n, h6, d1, d2, d3, d4, x)
    integer, intent(in) :: n
    real(wp), intent(in) :: h6, d1(n), d2(n), d3(n), d4(n)
    real(wp), intent(inout) :: x(n)
    x = x + h6*(d1 + 2.0_wp*(d2 + d3) + d4)
  end subroutine rk4_combine

  !> c = a b for the small matrices of the sensitivity equations, column by
  !> column (the sums in matmul's order, without its zeroing and
  !> temporaries: this runs at every stage and sample).
  subroutine small_product(a, b, c)
    real(wp), intent(in) :: a(:, :), b(:, :)
    real(wp), intent(out) :: c(:, :)
    if (size(a, 2) == 0) then
      c = 0.0_wp
    else if (size(a, 1) == 4 .and. size(a, 2) == 4) then   ! four states: fixed-size kernel
      call product_4x4(size(b, 2), a, b, c)
    else if (size(a, 1) == 7 .and. size(a, 2) == 4) then   ! seven outputs of four states
      call product_7x4(size(b, 2), a, b, c)
    else if (size(a, 1) == 7 .and. size(a, 2) == 7) then   ! seven states (flight path)
      call product_7x7(size(b, 2), a, b, c)
    else if (size(a, 2) == 4) then                            ! outputs of four states
      call product_nx4(size(a, 1), size(b, 2), a, b, c)
    else               ! the arrays are contiguous here: no copies
      call product_columns(size(a, 1), size(a, 2), size(b, 2), a, b, c)
    end if
  end subroutine small_product

  !> c = a b, all contiguous (explicit shape, so the loops run on unit
  !> strides); four terms of each sum at a time, added left to right, so
  !> the sums are matmul's to the bit.
  pure subroutine product_columns(n, m, l, a, b, c)
    integer, intent(in) :: n, m, l
    real(wp), intent(in) :: a(n, m), b(m, l)
    real(wp), intent(out) :: c(n, l)
    integer :: j, k, kend
    if (m < 4) then
      do j = 1, l
        c(:, j) = a(:, 1)*b(1, j)
        do k = 2, m
          c(:, j) = c(:, j) + a(:, k)*b(k, j)
        end do
      end do
      return
    end if
    kend = 4 + 4*((m - 4)/4)                 ! the last term of the whole blocks of four
    do j = 1, l
      c(:, j) = a(:, 1)*b(1, j) + a(:, 2)*b(2, j) + a(:, 3)*b(3, j) + a(:, 4)*b(4, j)
      do k = 5, kend - 3, 4
        c(:, j) = c(:, j) + a(:, k)*b(k, j) + a(:, k + 1)*b(k + 1, j) + a(:, k + 2)*b(k + 2, j) &
                  + a(:, k + 3)*b(k + 3, j)
      end do
      do k = kend + 1, m
        c(:, j) = c(:, j) + a(:, k)*b(k, j)
      end do
    end do
  end subroutine product_columns

  !> c = a b for a 4 x 4 (four states, as the longitudinal models have):
  !> the sizes known to the compiler, so each column is four whole-vector
  !> multiply-adds without loop overhead; the terms added left to right as
  !> in product_columns' first block of four, so the sums are the same to
  !> the bit.
  pure subroutine product_4x4(l, a, b, c)
    integer, intent(in) :: l
    real(wp), intent(in) :: a(4, 4), b(4, l)
    real(wp), intent(out) :: c(4, l)
    integer :: j
    do j = 1, l
      c(:, j) = a(:, 1)*b(1, j) + a(:, 2)*b(2, j) + a(:, 3)*b(3, j) + a(:, 4)*b(4, j)
    end do
  end subroutine product_4x4

  !> c = a b for a 7 x 4 (the outputs' C S of the longitudinal models and
  !> the X-22's: seven outputs, four states): product_nx4 with the rows'
  !> count known to the compiler (no loop over them), the same sums.
  pure subroutine product_7x4(l, a, b, c)
    integer, intent(in) :: l
    real(wp), intent(in) :: a(7, 4), b(4, l)
    real(wp), intent(out) :: c(7, l)
    integer :: j
    do j = 1, l
      c(:, j) = a(:, 1)*b(1, j) + a(:, 2)*b(2, j) + a(:, 3)*b(3, j) + a(:, 4)*b(4, j)
    end do
  end subroutine product_7x4

  !> c = a b for a 7 x 7 (the flight-path models' seven states, and their
  !> seven outputs' C S): the sizes known to the compiler; the terms added
  !> left to right, as product_columns adds its first four and then the
  !> rest one by one, so the sums are the same to the bit.
  pure subroutine product_7x7(l, a, b, c)
    integer, intent(in) :: l
    real(wp), intent(in) :: a(7, 7), b(7, l)
    real(wp), intent(out) :: c(7, l)
    integer :: j
    do j = 1, l
      c(:, j) = a(:, 1)*b(1, j) + a(:, 2)*b(2, j) + a(:, 3)*b(3, j) + a(:, 4)*b(4, j) &
                + a(:, 5)*b(5, j) + a(:, 6)*b(6, j) + a(:, 7)*b(7, j)
    end do
  end subroutine product_7x7

  !> c = a b + the first columns of d for a 7 x 4 a: c(:, j) = a b(:, j) +
  !> w(j) d(:, j) for j <= nd, a b(:, j) after; each sum product_7x4's, then
  !> d's term added, in one pass: the sums of product_7x4 followed by
  !> c(:, j) += w(j) d(:, j), to the bit (the outputs' sensitivities
  !> C S + dh/dp when the model parameters are the first columns).
  pure subroutine product_7x4_add(l, nd, a, b, d, w, c)
    integer, intent(in) :: l, nd
    real(wp), intent(in) :: a(7, 4), b(4, l), d(7, nd), w(nd)
    real(wp), intent(out) :: c(7, l)
    integer :: j
    do j = 1, nd
      c(:, j) = a(:, 1)*b(1, j) + a(:, 2)*b(2, j) + a(:, 3)*b(3, j) + a(:, 4)*b(4, j) &
                + w(j)*d(:, j)
    end do
    if (l > nd) call product_7x4(l - nd, a, b(1, nd + 1), c(1, nd + 1))
  end subroutine product_7x4_add

  !> product_7x4_add where d(1:4, :) is zero (model_t%param_rows: dh/dp
  !> moves outputs 5 to 7 alone, as the longitudinal model's): d's last
  !> three rows alone added, the same sums to the bit (w*0 left out, as in
  !> add_forcing).  At most the sign of a zero in c can differ (where all
  !> four products of a row of C S are -0 and d's entry +0: never for the
  !> longitudinal model, whose first four rows of C are the identity's and
  !> whose sensitivities are never -0), which no sum or product of c sees.
  pure subroutine product_7x4_add_tail(l, nd, a, b, d, w, c)
    integer, intent(in) :: l, nd
    real(wp), intent(in) :: a(7, 4), b(4, l), d(7, nd), w(nd)
    real(wp), intent(out) :: c(7, l)
    integer :: j
    do j = 1, nd
      c(1:4, j) = a(1:4, 1)*b(1, j) + a(1:4, 2)*b(2, j) + a(1:4, 3)*b(3, j) + a(1:4, 4)*b(4, j)
      c(5:7, j) = a(5:7, 1)*b(1, j) + a(5:7, 2)*b(2, j) + a(5:7, 3)*b(3, j) + a(5:7, 4)*b(4, j) &
                  + w(j)*d(5:7, j)
    end do
    if (l > nd) call product_7x4(l - nd, a, b(1, nd + 1), c(1, nd + 1))
  end subroutine product_7x4_add_tail

  !> Whether dh/dp with the structure hrow (model_t%param_rows) is zero in
  !> its first four rows: product_7x4_add_tail's condition.
  pure logical function past_states(hrow)
    integer, intent(in) :: hrow(:, :)
    past_states = all(hrow(1, :) >= 5) .and. all(hrow == 0 .or. hrow >= 5)
  end function past_states

  !> c = a b for an n x 4 (the outputs' C S of four states): as product_4x4
  !> with the rows' count known at run time only, the same sums.
  pure subroutine product_nx4(n, l, a, b, c)
    integer, intent(in) :: n, l
    real(wp), intent(in) :: a(n, 4), b(4, l)
    real(wp), intent(out) :: c(n, l)
    integer :: j
    do j = 1, l
      c(:, j) = a(:, 1)*b(1, j) + a(:, 2)*b(2, j) + a(:, 3)*b(3, j) + a(:, 4)*b(4, j)
    end do
  end subroutine product_nx4

end module mlid_rk
